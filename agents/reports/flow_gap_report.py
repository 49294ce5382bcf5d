"""``flow_gap.md``: what optical flow costs a learned policy, written from the committed data alone.

The thesis's question for a learned policy is the gap between the same recipe trained on the estimator's depths
and on the true depths at the same tracked points. Two recipes answer it: the plain one (``ppo_flow`` against
``ppo_oracle``) and the lever search's pick against its recipe on true depths. Each gap is paired by layout
(:func:`agents.analysis.paired.compare`): every training seed of both agents flew the same layouts, the
interval resamples training seeds (each agent's apart) and layouts (once for both). The sources are the
confirmation flights on fresh validation layouts (``results/confirmation/``), the suite's frozen test layouts
(``results/suite_episodes.csv``, the current suite version) and the leading clean table. The prose is ``templates/flow_gap.md.j2``, the
benchmark's values (:mod:`agents.reports.benchmark_report`) beside this report's own; nothing is flown.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from agents.analysis.episode_record import EpisodeRow
from agents.analysis.family import correct_family
from agents.analysis.over_seeds import episode_outcomes
from agents.analysis.paired import Comparison, compare, provisional_note, runs_interval, verdict
from agents.analysis.records import read_records
from agents.analysis.statistics import runs_failure
from agents.analysis.validation_rows import ConfirmationResult, SearchRecord
from agents.common.agent_table import AGENTS
from agents.common.folders import check_writable_folder, write_text_atomically
from agents.common.locations import POLICIES_DIR
from agents.common.seeds import suite_seeds
from agents.common.study_choices import choices
from agents.common.tables import markdown_table, today
from agents.evaluation.suite import EPISODES_CSV, SUITE_RESULTS_FOLDERS
from agents.pages.wording import render_report
from agents.policies import is_learned, shipped_seed_runs
from agents.reports.benchmark_report import report_values
from agents.reports.flow_gap_types import FlowGapValues, PlainGapValues, SelectionValues, StudentGapValues
from agents.studies.benchmark_data import BenchmarkData, Rate, load_benchmark_data
from agents.studies.confirmation import (
    COMPARED,
    CONFIRMATION_LAYOUTS,
    FLOWN_AFTER_THE_SEARCH,
    PICK,
    TRUE_DEPTH_RECIPE,
    flow_costs,
    outcome_matrices,
    run_confirmation,
    search_record,
)
from flownav_env.tiers import SUITE_VERSION, TIER_NAMES

# The suite version whose frozen layouts this page reads: the current one; a pair of agents not yet flown whole on
# a tier is left out of that tier (results/suite.md lists what is left).
READ_SUITE_VERSION = SUITE_VERSION

Cell = tuple[float, float, float]  # a failure rate and its 95 % interval
Row = tuple[str, np.ndarray, np.ndarray]  # where, flow's failures, truth's failures (runs, layouts)
Bar = tuple[str, Cell | None, Cell | None]  # where, flow's failure, truth's failure (None: not flown)


def gap(flow: np.ndarray, truth: np.ndarray, names: tuple[str, str] = ("flow", "truth")) -> Comparison:
    """Flow minus truth, paired by layout: both (runs, layouts) of failures on the same layouts; ``names``, the
    two agents, let a reading say which one rests on few training seeds."""
    return compare(names[0], flow, names[1], truth)


def _cell(matrix: np.ndarray) -> Cell:
    """A failure rate with its interval: for several training runs the wider of the two-level bootstrap and the
    t-interval over the runs' own rates (:func:`agents.analysis.paired.runs_interval`, suite.md's rule);
    Wilson's over layouts for one run, such as the planner's."""
    if len(matrix) > 1:
        return (float(matrix.mean()), *runs_interval(matrix))
    return (float(matrix.mean()), *runs_failure(1 - matrix)[1:])


def _leaderboard_cell(data: BenchmarkData, agent: str) -> Cell:
    row = data.row(agent)
    return (row["failure_rate"], row["failure_low"], row["failure_high"])


def _rate_cell(rate: Rate) -> Cell:
    return (rate.rate, rate.low, rate.high)


def gap_row(
    label: str, flow: np.ndarray, truth: np.ndarray, names: tuple[str, str] = ("flow", "truth")
) -> list[str]:
    """A table row: each agent's failure with its interval, flow minus truth paired by layout, its verdict, marked
    provisional where a learned agent among ``names`` pooled fewer training seeds than a ranked one needs."""
    found = gap(flow, truth, names)
    cells = [f"{rate:.2f} [{low:.2f}, {high:.2f}]" for rate, low, high in (_cell(flow), _cell(truth))]
    return [
        label,
        *cells,
        f"{found.difference:+.3f} [{found.low:+.3f}, {found.high:+.3f}]",
        verdict(found, "flow", "truth") + provisional_note(found),
    ]


def gap_table(
    flow: str, truth: str, rows: Sequence[Row], where: str, ceiling: Mapping[str, np.ndarray] | None = None
) -> str:
    """The gap per row; with ``ceiling`` (row label → the planner's failures, one run), its failure beside."""
    header = [where, f"`{flow}` (flow)", f"`{truth}` (true depths)", "flow − truth [95 % CI]", "reading"]
    if ceiling is None:
        return markdown_table(header, [gap_row(*row, (flow, truth)) for row in rows]) if rows else ""
    cells = {label: "{:.2f} [{:.2f}, {:.2f}]".format(*_cell(found)) for label, found in ceiling.items()}
    body = [[*gap_row(*row, (flow, truth)), cells.get(row[0], "not flown")] for row in rows]
    return markdown_table([*header, "`planner` (the ceiling)"], body) if rows else ""


def _episodes(path: Path) -> tuple[EpisodeRow, ...]:
    """The episode records at ``path``, read once per version of the file: the report draws a dozen agents'
    matrices from the suite's tens of thousands of episodes."""
    status = path.stat()
    return _read_once(str(path), status.st_mtime_ns, status.st_size)


@functools.lru_cache(maxsize=2)
def _read_once(path: str, _mtime_ns: int, _size: int) -> tuple[EpisodeRow, ...]:
    return tuple(read_records(Path(path)))


def suite_matrices(results: Path, agent: str, policies_dir: Path = POLICIES_DIR) -> dict[str, np.ndarray]:
    """tier → failures (runs, layouts) of ``agent``'s shipped seeds (a rule or planner: its one run) on the
    suite's frozen layouts, for the tiers every run has flown whole."""
    path = results / SUITE_RESULTS_FOLDERS[READ_SUITE_VERSION] / EPISODES_CSV
    runs = shipped_seed_runs(agent, policies_dir) if is_learned(agent) else [agent]
    if not path.is_file() or not runs:
        return {}
    rows = [row for row in _episodes(path) if row["agent"] in runs]
    found = {}
    for tier_name in TIER_NAMES:
        try:
            mine = [row for row in rows if row["factor"] == tier_name]
            found[tier_name] = episode_outcomes(
                mine, runs, list(suite_seeds(version=READ_SUITE_VERSION)), "failure"
            )
        except ValueError:
            continue
    return found


def _suite_rows(results: Path, flow: str, truth: str, policies_dir: Path) -> list[Row]:
    flow_tiers, truth_tiers = (suite_matrices(results, a, policies_dir) for a in (flow, truth))
    return [(t, flow_tiers[t], truth_tiers[t]) for t in TIER_NAMES if t in flow_tiers and t in truth_tiers]


def _student_values(results: Path, policies_dir: Path) -> StudentGapValues:
    """The planner's flow-only student against its true-depth twin per tier, the planner beside as ceiling."""
    student, twin = choices().student, choices().student_truth
    return StudentGapValues(
        student=student,
        student_truth=twin,
        student_truth_seeds=len(shipped_seed_runs(twin, policies_dir)),
        student_not_flown=not_flown_here(student, twin),
        student_suite_table=gap_table(
            student,
            twin,
            _suite_rows(results, student, twin, policies_dir),
            "tier",
            ceiling=suite_matrices(results, "planner", policies_dir),
        ),
    )


def confirmation_rows(result: ConfirmationResult, results: Path, policies_dir: Path) -> list[Row]:
    """The pick against its true-depth recipe per condition on the confirmation layouts; empty until the
    true-depth recipe has flown."""
    if not flow_costs(result):
        return []
    agents = (PICK, TRUE_DEPTH_RECIPE)
    matrices = outcome_matrices(results / "confirmation", agents, result.layouts, policies_dir)
    return [
        (k, found[PICK], found[TRUE_DEPTH_RECIPE])
        for k, found in matrices.items()
        if set(agents) <= set(found)
    ]


def selection_values(result: ConfirmationResult, search: SearchRecord) -> SelectionValues:
    """The search as it happened and what the fresh layouts say about the pick: the pick's rises over its clean
    rate, and its differences from its first stage and from ``ppo_flow``."""
    return SelectionValues(
        search=search,
        confirmation_layouts=result.layouts,
        pick_rises=[r for r in result.rises if r.agent == PICK],
        first_stage=COMPARED[0],
        stages={other: [d for d in result.differences if d.other == other] for other in COMPARED},
        after_the_search=[f"`{name}`" for name in FLOWN_AFTER_THE_SEARCH],
    )


def not_flown_here(*agents: str) -> dict[str, str]:
    """Why each of ``agents`` that the suite version this page reads does not fly is left off it (the agent
    table's ``not_flown_on``), by agent."""
    return {
        agent: why
        for agent in agents
        for version, why in AGENTS[agent].not_flown_on
        if version == READ_SUITE_VERSION
    }


def _plain_values(data: BenchmarkData, results: Path, policies_dir: Path) -> PlainGapValues:
    flow, truth = choices().plain
    clean = data.validation["clean"]
    return PlainGapValues(
        plain_steps=[data.training[a].config["total_timesteps"] for a in (flow, truth)],
        plain_validation=[clean[flow], clean[truth]],
        plain_suite_table=gap_table(flow, truth, _suite_rows(results, flow, truth, policies_dir), "tier"),
        plain_not_flown=not_flown_here(flow, truth),
    )


def gap_bars(
    data: BenchmarkData, result: ConfirmationResult, results: Path, policies_dir: Path
) -> dict[str, list[Bar]]:
    """What the figure shows, per recipe: (where, flow's failure, truth's failure), None where not flown."""
    plain_flow, plain_truth = choices().plain
    clean = data.validation["clean"]
    plain: list[Bar] = [
        ("test, clean", _leaderboard_cell(data, plain_flow), _leaderboard_cell(data, plain_truth)),
        ("validation, clean", _rate_cell(clean[plain_flow]), _rate_cell(clean[plain_truth])),
    ]
    rates = {(r.condition, r.agent): (r.failure, r.low, r.high) for r in result.rates}
    pick: list[Bar] = [
        (f"fresh validation, {k}", rates.get((k, PICK)), rates.get((k, TRUE_DEPTH_RECIPE)))
        for k in dict.fromkeys(r.condition for r in result.rates)
    ]
    for bars, agents in ((plain, (plain_flow, plain_truth)), (pick, (PICK, TRUE_DEPTH_RECIPE))):
        flow_tiers, truth_tiers = (suite_matrices(results, a, policies_dir) for a in agents)
        bars += [
            (
                f"suite, {t}",
                _cell(flow_tiers[t]) if t in flow_tiers else None,
                _cell(truth_tiers[t]) if t in truth_tiers else None,
            )
            for t in TIER_NAMES
            if t in flow_tiers or t in truth_tiers
        ]
    return {f"`{plain_flow}` / `{plain_truth}`": plain, f"the pick / {TRUE_DEPTH_RECIPE}": pick}


def plot_gap(panels: Mapping[str, Sequence[Bar]], path: Path) -> None:
    """A panel per recipe: flow's and truth's failure side by side where each was flown, 95 % intervals."""
    # matplotlib takes a second to import: only the writers that draw a figure load it.
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    widths = [max(1, len(bars)) for bars in panels.values()]
    fig, axes = plt.subplots(
        1,
        len(panels),
        figsize=(1.0 + 0.9 * sum(widths), 4.0),
        gridspec_kw={"width_ratios": widths},
        squeeze=False,
    )
    for ax, (title, bars) in zip(axes[0], panels.items(), strict=True):
        for offset, (flow, colour, name) in (
            (-0.2, (True, "tab:blue", "flow")),
            (0.2, (False, "tab:orange", "true depths")),
        ):
            xs: list[float] = []
            ys: list[float] = []
            errors: list[list[float]] = [[], []]
            for x, (_, flow_cell, truth_cell) in enumerate(bars):
                cell = flow_cell if flow else truth_cell
                if cell is not None:
                    xs.append(x + offset)
                    ys.append(cell[0])
                    errors[0].append(cell[0] - cell[1])
                    errors[1].append(cell[2] - cell[0])
            ax.bar(xs, ys, width=0.4, yerr=errors, capsize=3, color=colour, alpha=0.8, label=name)
        ax.set_xticks(range(len(bars)), [bar[0] for bar in bars], rotation=35, ha="right", fontsize=8)
        ax.set_ylim(0, 1)
        ax.set_title(title.replace("`", ""), fontsize=9)
        ax.grid(alpha=0.3, axis="y")
        if not any(bar[2] for bar in bars):
            ax.text(
                0.5, 0.9, "true-depth recipe not trained yet", transform=ax.transAxes, ha="center", fontsize=8
            )
    axes[0][0].set_ylabel("failure rate (95 % CI)")
    axes[0][0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def flow_gap_values(
    results_dir: Path,
    policies_dir: Path = POLICIES_DIR,
    result: ConfirmationResult | None = None,
    data: BenchmarkData | None = None,
    *,
    generated: str,
    command: str,
) -> FlowGapValues:
    """Every value of the flow-gap template, from the committed data under ``results_dir``, with the date and
    the command that wrote the page; ``result``: the confirmation's comparison (:func:`run_confirmation`) and
    ``data`` the benchmark's summaries, when the caller has them already."""
    results = Path(results_dir)
    data = data if data is not None else load_benchmark_data(results)
    if result is None:
        result = run_confirmation(results / "confirmation", report_only=True, policies_dir=policies_dir)
    confirmation = confirmation_rows(result, results, policies_dir)
    pick_suite = _suite_rows(results, PICK, TRUE_DEPTH_RECIPE, policies_dir)
    family = [(f"{where}, fresh validation", gap(flow, truth)) for where, flow, truth in confirmation]
    family += [(f"`{tier_name}`, suite", gap(flow, truth)) for tier_name, flow, truth in pick_suite]
    # Each part is handed on whole, by its fields (``vars``: shallow, as the template is given them).
    return FlowGapValues(
        **vars(report_values(data)),
        generated=generated,
        command=command,
        **vars(_plain_values(data, results, policies_dir)),
        **vars(selection_values(result, search_record(results / "ablation"))),
        **vars(_student_values(results, policies_dir)),
        # The page's flow − truth comparisons as one family (Holm): each table reads them one by one.
        gap_family=correct_family(family),
        truth_seeds={
            Path(c).stem: len(shipped_seed_runs(Path(c).stem, policies_dir)) for c in choices().truth_stages
        },
        seeds_wanted=choices().gap_seeds,
        true_depth_stages=choices().truth_stages,
        truth_confirmation_table=gap_table(PICK, TRUE_DEPTH_RECIPE, confirmation, "condition"),
        truth_confirmation=[(where, gap(flow, truth)) for where, flow, truth in confirmation],
        truth_suite_table=gap_table(PICK, TRUE_DEPTH_RECIPE, pick_suite, "tier"),
        suite_version=READ_SUITE_VERSION,
        confirmation_layouts_wanted=CONFIRMATION_LAYOUTS,
    )


def write_flow_gap(
    results_dir: Path, out: Path, command: str, policies_dir: Path = POLICIES_DIR
) -> list[str]:
    """Write ``out/flow_gap.md`` and its figure ``flow_gap.png`` from the committed data under ``results_dir``
    (a folder with the layout of ``results/``), matching flights to the training seeds shipped to
    ``policies_dir``; returns the report's lines.

    Raises:
        FileNotFoundError: a missing input, named in one line.
        ValueError: an unwritable ``out``, or data the report cannot be worded from.
    """
    results = Path(results_dir)
    result = run_confirmation(results / "confirmation", report_only=True, policies_dir=policies_dir)
    data = load_benchmark_data(results)  # read once: the values and the figure draw on it
    values = flow_gap_values(results, policies_dir, result, data, generated=today(), command=command)
    text = render_report("flow_gap.md.j2", values)
    out = Path(out)
    check_writable_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    plot_gap(gap_bars(data, result, results, policies_dir), out / "flow_gap.png")
    write_text_atomically(out / "flow_gap.md", text)
    return text.splitlines()
