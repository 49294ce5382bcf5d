"""The sweep's page: the collision-against-error figure and ``sweep.md``, from what
:func:`~agents.evaluation.sweep.run_sweep` flew and summarised (its summary CSV is
:mod:`agents.evaluation.sweep_summary`'s)."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from agents.analysis.episode_record import EpisodeRow
from agents.analysis.records import read_records
from agents.analysis.statistics import CellSummary, format_summary, summarise
from agents.common.machine import code_version
from agents.evaluation.provenance import machine_summary
from agents.evaluation.sweep import SweepFlight
from flownav_env.settings import ENV_ESTIMATOR_DEFAULTS, EnvSettings

if TYPE_CHECKING:  # matplotlib is heavy: imported only where a figure is drawn
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

# Each factor's axis label in the figure: what the level measures, and in what unit.
FACTOR_AXIS_LABELS = {
    "rotation_error": "rotation error (relative)",
    "translation_error": "translation error (relative)",
    "attitude_jitter_deg": "attitude jitter (deg)",
    "brightness": "brightness (1 = daylight)",
    "forward_speed": "forward speed (m/s; ×0.1 = m per frame)",
    "obstacle_density": "obstacle density (capsules per m²)",
    "rotation_bias": "rotation bias (relative scale error)",
    "translation_bias": "translation bias (relative scale error)",
    "rotation_drift": "rotation bias drift (std after 1 s)",
    "translation_drift": "translation bias drift (std after 1 s)",
    "rotation_noise_deg": "rotation noise floor (deg per frame, std)",
    "translation_noise_m": "translation noise floor (m per frame, std)",
    "depth_noise": "depth noise (σ of log depth)",
    "depth_outliers": "depth outliers (fraction)",
    "depth_dropout": "depth dropout (fraction)",
}


def plot_collision_vs_error(table: Sequence[CellSummary], factors: list[str], path: Path) -> None:
    """A panel per factor: failure rate against level, a line per agent with its Wilson 95 % band shaded, and
    the collision rate dashed in the same colour (the gap between them is leaving the course or the time
    limit). The clean setting is drawn at each factor's neutral level; a sweep of no factors gets a bar per
    agent (failure, with the collision rate marked)."""
    import matplotlib  # heavy: only a command that draws the figure pays for it

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # only once the backend is chosen

    if not factors:
        fig = _clean_bars([r for r in table if r["factor"] == "clean"])
        fig.savefig(path, dpi=120)
        plt.close(fig)
        return
    # Numeric settings only: a factor is swept over numbers, so only these can be one's neutral level.
    neutral = {
        setting.name: float(setting.default)
        for setting in dataclasses.fields(EnvSettings)
        if isinstance(setting.default, (int, float))
    }
    agents = sorted({r["agent"] for r in table})
    # A grid, not a row: fifteen factors side by side made a figure 54 inches wide.
    columns = min(4, len(factors))
    rows = -(-len(factors) // columns)
    fig, axes = plt.subplots(
        rows, columns, figsize=(3.6 * columns, 3.0 * rows + 0.6), sharey=True, squeeze=False
    )
    for ax in axes.flat[len(factors) :]:
        ax.set_visible(False)
    for ax, factor in zip(axes.flat, factors, strict=False):
        for agent in agents:
            _plot_agent_line(ax, table, agent, factor, neutral.get(factor, 0.0))
        ax.set_xlabel(FACTOR_AXIS_LABELS.get(factor, factor))
        ax.set_ylim(0, 1)
        ax.grid(alpha=0.3)
    for ax in axes[:, 0]:
        ax.set_ylabel("failure rate (95 % CI)\ndashed: collision rate")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="upper center", ncol=min(len(labels), 8), fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0, 1, 1 - 0.35 / (3.0 * rows + 0.6)))
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _clean_bars(clean: Sequence[CellSummary]) -> Figure:
    """The figure of a clean-only sweep: one bar per agent, its failure rate with its interval, the
    collision rate marked."""
    import matplotlib.pyplot as plt  # heavy; the caller has chosen the Agg backend

    fig, ax = plt.subplots(figsize=(1.0 + 1.2 * len(clean), 3.4))
    rates = [r["failure_rate"] for r in clean]
    errors = [
        [r["failure_rate"] - r["failure_ci_low"] for r in clean],
        [r["failure_ci_high"] - r["failure_rate"] for r in clean],
    ]
    names = [r["agent"] for r in clean]
    ax.bar(names, rates, yerr=errors, capsize=4, color="tab:blue", alpha=0.7, label="failure")
    ax.plot(names, [r["collision_rate"] for r in clean], "k_", markersize=18, label="collision")
    ax.legend(fontsize=8)
    ax.set_ylim(0, 1)
    ax.set_ylabel("failure rate (95 % CI)")
    ax.set_title("clean sensors", fontsize=9)
    ax.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    return fig


def _plot_agent_line(ax: Axes, table: Sequence[CellSummary], agent: str, factor: str, neutral: float) -> None:
    """One agent's failure rate against the factor's level (its clean cell at ``neutral``), its interval
    shaded and its collision rate dashed; nothing where the agent has no cell."""
    points = [(neutral, r) for r in table if r["agent"] == agent and r["factor"] == "clean"]
    points += [(r["level"], r) for r in table if r["agent"] == agent and r["factor"] == factor]
    points.sort(key=lambda p: p[0])
    if not points:
        return
    xs = [p[0] for p in points]
    line = ax.plot(xs, [p[1]["failure_rate"] for p in points], marker="o", label=agent)[0]
    ax.fill_between(
        xs,
        [p[1]["failure_ci_low"] for p in points],
        [p[1]["failure_ci_high"] for p in points],
        color=line.get_color(),
        alpha=0.15,
    )
    ax.plot(xs, [p[1]["collision_rate"] for p in points], linestyle="--", color=line.get_color())


def pivot_markdown(table: Sequence[CellSummary], factor: str) -> str:
    """Failure rate [95 % CI] (collision rate) per agent (rows) and level (columns) of one factor, the clean
    run first."""
    agents = sorted({r["agent"] for r in table})
    levels = sorted({r["level"] for r in table if r["factor"] == factor})
    cells = {(r["agent"], r["factor"], r["level"]): r for r in table}
    header = "| agent | clean | " + " | ".join(f"{factor}={level:g}" for level in levels) + " |"
    lines = [header, "|---" * (len(levels) + 2) + "|"]
    for agent in agents:
        row = [cells.get((agent, "clean", 0.0))] + [cells.get((agent, factor, level)) for level in levels]
        lines.append(
            f"| {agent} | "
            + " | ".join(
                "–"
                if r is None
                else f"{r['failure_rate']:.2f} [{r['failure_ci_low']:.2f}, {r['failure_ci_high']:.2f}] "
                f"({r['collision_rate']:.2f})"
                for r in row
            )
            + " |"
        )
    return "\n".join(lines)


def comparison_markdown(rows: Sequence[EpisodeRow], baseline_rows: Sequence[EpisodeRow]) -> str:
    """Collision rate per cell (rows) and agent (columns), beside the same cell of a baseline sweep, and per
    agent the share of the seeds flown in both whose episode ended the same way (collision or not): rates can
    agree while single episodes differ, e.g. on another renderer."""
    table, baseline = summarise(rows), summarise(baseline_rows)
    agents = sorted({r["agent"] for r in table})
    cells = {(r["agent"], r["factor"], r["level"]): r for r in table}
    before = {(r["agent"], r["factor"], r["level"]): r for r in baseline}
    agreement = _same_outcomes(rows, baseline_rows)
    keys = sorted({(r["factor"], r["level"]) for r in table}, key=lambda k: (k[0] != "clean", k))
    names = " / ".join(agents)
    header = (
        f"| factor | level | episodes | {' | '.join(agents)} | baseline: {names} | same outcome: {names} |"
    )
    lines = [header, "|---" * (len(agents) + 5) + "|"]
    for factor, level in keys:
        episodes = _episodes_range(cells, agents, factor, level)
        lines.append(
            f"| {factor} | {'–' if factor == 'clean' else f'{level:g}'} | {episodes} | "
            + " | ".join(_collision_rate(cells.get((a, factor, level))) for a in agents)
            + " | "
            + " / ".join(_collision_rate(before.get((a, factor, level))) for a in agents)
            + " | "
            + " / ".join(_agreement_share(agreement.get((a, factor, level))) for a in agents)
            + " |"
        )
    return "\n".join(lines)


def _same_outcomes(
    rows: Sequence[EpisodeRow], baseline_rows: Sequence[EpisodeRow]
) -> dict[tuple[str, str, float], list[bool]]:
    """Per (agent, factor, level), for each seed flown in both sweeps, whether it collided in both or in
    neither."""
    outcomes: dict[tuple[str, str, float], dict[int, bool]] = {}
    for row in baseline_rows:
        outcomes.setdefault((row["agent"], row["factor"], float(row["level"])), {})[row["seed"]] = row[
            "collision"
        ]
    agreement: dict[tuple[str, str, float], list[bool]] = {}
    for row in rows:
        key = (row["agent"], row["factor"], float(row["level"]))
        if row["seed"] in outcomes.get(key, {}):
            agreement.setdefault(key, []).append(outcomes[key][row["seed"]] == row["collision"])
    return agreement


def _episodes_range(
    cells: Mapping[tuple[str, str, float], CellSummary], agents: list[str], factor: str, level: float
) -> str:
    """The episodes of a (factor, level)'s cells: one count, or the fewest–most where agents differ."""
    counts = sorted({cells[(a, factor, level)]["episodes"] for a in agents if (a, factor, level) in cells})
    return str(counts[0]) if len(counts) == 1 else f"{counts[0]}–{counts[-1]}"


def _collision_rate(row: CellSummary | None) -> str:
    return "–" if row is None else f"{row['collision_rate']:.2f}"


def _agreement_share(same: list[bool] | None) -> str:
    return "–" if not same else f"{sum(same)}/{len(same)}"


def partial_lines(
    table: Sequence[CellSummary], episodes_per_cell: int | None, expected_cells: int | None = None
) -> list[str]:
    """A warning for ``sweep.md`` while some cell has fewer than ``episodes_per_cell`` episodes, or fewer
    than ``expected_cells`` cells (the config's) have any (none when every cell is complete, or nothing is
    known of the target)."""
    if not episodes_per_cell or not table:
        return []
    short = [r for r in table if r["episodes"] < episodes_per_cell]
    missing = max(0, (expected_cells or 0) - len(table))
    if not short and not missing:
        return []
    total = len(table) + missing
    fewest = 0 if missing else min(r["episodes"] for r in table)
    unflown = f"; {missing} of them not flown at all" if missing else ""
    return [
        "",
        f"> **Partial: {len(short) + missing} of {total} cells have fewer than the config's {episodes_per_cell} "
        f"episodes** (fewest: {fewest}{unflown}). Their rates are over the layouts flown so far and their "
        "intervals are wider; the same command resumes the sweep.",
    ]


def write_report(
    path: Path,
    table: Sequence[CellSummary],
    config_path: Path,
    command: str,
    minutes: float | None,
    factors: list[str],
    comparison: tuple[Path, str] | None = None,
    episodes_per_cell: int | None = None,
    expected_cells: int | None = None,
) -> None:
    """``sweep.md``: how the sweep was run and its tables (interpretation belongs in benchmark.md);
    ``comparison`` is an earlier sweep's episodes CSV and :func:`comparison_markdown` against it. With
    ``episodes_per_cell`` (the config's), a sweep not yet flown in full says so at the top."""
    parts = [
        "# Sweep: failure rate per agent and sensor error",
        *partial_lines(table, episodes_per_cell, expected_cells),
        "",
        f"Command: `{command}`  ",
        f"Config: `{config_path}`  ",
        f"Env estimator defaults (under the config's `estimator_kwargs`): `{ENV_ESTIMATOR_DEFAULTS}`  ",
        f"Code when this report was written: {code_version()}  ",
        *(
            [
                f"Hardware: {machine_summary()}  ",
                f"Wall time of the last invocation: {minutes:.1f} min (episodes already in the CSV are not re-flown).",
            ]
            if minutes is not None
            else [
                "Rebuilt with `--report-only` from the episodes flown so far, on (the episodes may have been "
                f"flown elsewhere): {machine_summary()}"
            ]
        ),
        "",
        "```yaml",
        config_path.read_text().strip(),
        "```",
        "",
        "Failure rate (collision, out of bounds or time limit; success is one minus it) with its Wilson 95 % "
        "interval, and the collision rate in brackets, per factor (levels beyond the clean setting); every "
        "rate of every cell is in the last table:",
        "",
    ]
    for factor in factors:
        parts += [f"### {factor}", "", pivot_markdown(table, factor), ""]
    if comparison is not None:
        baseline_path, comparison_table = comparison
        parts += [
            f"## Against `{baseline_path}`",
            "",
            "Collision rate per cell beside the same cell there (– where it has none), and per agent how many of",
            "the seeds flown in both ended the same way (collision or not).",
            "",
            comparison_table,
            "",
        ]
    parts += ["## All cells", "", format_summary(table), ""]
    path.write_text("\n".join(parts))


def write_sweep_page(flight: SweepFlight, command: str) -> None:
    """``collision_vs_error.png`` and ``sweep.md`` in the sweep's folder: the summary, the flight time (none for a
    rebuilt report) and, with the flight's ``compare_with``, each cell beside the earlier sweep's."""
    config = flight.config
    plot_collision_vs_error(flight.table, list(config.factors), flight.folder / "collision_vs_error.png")
    write_report(
        flight.folder / "sweep.md",
        flight.table,
        flight.config_path,
        command,
        flight.minutes,
        list(config.factors),
        None
        if flight.compare_with is None
        else (flight.compare_with, comparison_markdown(flight.rows, read_records(flight.compare_with))),
        episodes_per_cell=config.episodes,
        expected_cells=len(flight.agents) * (1 + sum(len(levels) for levels in config.factors.values())),
    )
