"""``flow_gap.md``: what optical flow costs a learned policy, written from the committed data alone.

The thesis's question for a learned policy is the gap between the same recipe trained on the estimator's depths
and on the true depths at the same tracked points. Two recipes answer it: the plain one (``ppo_flow`` against
``ppo_oracle``) and the lever search's pick against its recipe on true depths (:data:`TRUE_DEPTH_RECIPE`). Each gap is
paired by layout: every training seed of both agents flew the same layouts, the interval resamples training seeds
(each agent's apart) and layouts (once for both). The sources are the confirmation flights on fresh validation
layouts (``results/confirmation/``), the suite's frozen test layouts (``results/suite_episodes.csv``) and, for
the plain recipe, the leading clean table. The prose is ``templates/flow_gap.md.j2``; nothing is flown.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from agents.common.folders import check_writable_folder, write_text_atomically
from agents.common.jinja_reports import render
from agents.common.locations import POLICIES_DIR
from agents.common.seeds import suite_seeds
from agents.common.tables import markdown_table, today
from agents.evaluation.over_seeds import episode_outcomes
from agents.evaluation.paired import Comparison, compare
from agents.evaluation.records import read_records
from agents.evaluation.suite import EPISODES_CSV
from agents.policies import shipped_seed_runs
from agents.studies.benchmark_claims import (
    difference,
    display_name,
    interval,
    join_words,
    paired_reading,
    verdict,
)
from agents.studies.benchmark_data import BenchmarkData, load_benchmark_data
from agents.studies.benchmark_report import PACKAGE
from agents.studies.benchmark_values import (
    Values,
    leaderboard_values,
    reactive_gap_values,
    validation_values,
)
from agents.studies.confirmation import (
    COMPARED,
    CONFIRMATION_LAYOUTS,
    FLOWN_AFTER_THE_SEARCH,
    PICK,
    TRUE_DEPTH_RECIPE,
    failure_interval_over_runs_and_layouts,
    flow_costs,
    run_confirmation,
    search_record,
)
from agents.studies.flow_gap_figure import Cell, plot_gap
from agents.studies.flow_gap_targets import flow_gap_target_values
from flownav_env.tiers import SUITE_VERSION, TIER_NAMES

FLOW_GAP_TEMPLATE = "flow_gap.md.j2"
# The plain recipe: PPO on the estimator's depths and on the true depths, all else the same.
PLAIN_FLOW, PLAIN_TRUTH = "ppo_flow", "ppo_oracle"
# How many training seeds a recipe's gap is measured over.
SEEDS_WANTED = 5
TRUE_DEPTH_STAGES = (
    "configs/experiments/ppo_flow_course_approach_oracle.yaml",
    "configs/experiments/ppo_flow_course_approach_curriculum_slow_oracle.yaml",
)


def gap(flow: np.ndarray, truth: np.ndarray) -> Comparison:
    """Flow minus truth, paired by layout (:func:`agents.evaluation.paired.compare`): both (runs, layouts) of
    failures on the same layouts."""
    return compare("flow", flow, "truth", truth)


def gap_row(label: str, flow: np.ndarray, truth: np.ndarray) -> list[str]:
    """A table row: each agent's failure with its interval, flow minus truth paired by layout, its verdict."""
    found = gap(flow, truth)
    return [
        label,
        interval(flow.mean(), *failure_interval_over_runs_and_layouts(flow)),
        interval(truth.mean(), *failure_interval_over_runs_and_layouts(truth)),
        difference(found),
        verdict(found, "flow", "truth"),
    ]


def gap_table(flow: str, truth: str, rows: Sequence[list[str]], where: str) -> str:
    header = [where, f"`{flow}` (flow)", f"`{truth}` (true depths)", "flow − truth [95 % CI]", "reading"]
    return markdown_table(header, rows)


def suite_matrices(results: Path, agent: str, policies_dir: Path = POLICIES_DIR) -> dict[str, np.ndarray]:
    """tier → failures (runs, layouts) of ``agent``'s shipped seeds on the suite's frozen layouts, for the
    tiers every run has flown whole."""
    path = results / EPISODES_CSV
    runs = shipped_seed_runs(agent, policies_dir)
    if not path.is_file() or not runs:
        return {}
    rows = [row for row in read_records(path) if row["agent"] in runs]
    layouts = list(suite_seeds())
    found = {}
    for tier_name in TIER_NAMES:
        try:
            found[tier_name] = episode_outcomes(
                [row for row in rows if row["factor"] == tier_name], runs, layouts, "failure"
            )
        except ValueError:
            continue
    return found


def leaderboard_matrix(
    data: BenchmarkData, results: Path, agent: str, policies_dir: Path
) -> np.ndarray | None:
    """Failures (runs, layouts) of ``agent``'s shipped seeds on the leading clean table's test layouts, or None
    where it is not in that table (not flown yet)."""
    runs = shipped_seed_runs(agent, policies_dir)
    if not runs or not any(r["agent"] == agent for r in data.leaderboard):
        return None
    rows = [row for row in read_records(results / "leaderboard_episodes.csv") if row["agent"] in runs]
    return episode_outcomes(rows, runs, data.layouts, "failure")


def _test_gap(data: BenchmarkData, results: Path, policies_dir: Path) -> tuple[bool, str]:
    """The pick against its recipe on true depths on the leading clean table's test layouts, paired by layout."""
    flow, truth = (leaderboard_matrix(data, results, a, policies_dir) for a in (PICK, TRUE_DEPTH_RECIPE))
    if flow is None or truth is None:
        return False, ""
    return True, gap_table(PICK, TRUE_DEPTH_RECIPE, [gap_row("clean", flow, truth)], "test layouts")


def _suite_gap(results: Path, flow: str, truth: str, policies_dir: Path) -> tuple[bool, str]:
    flow_tiers, truth_tiers = (suite_matrices(results, a, policies_dir) for a in (flow, truth))
    rows = [
        gap_row(t, flow_tiers[t], truth_tiers[t]) for t in TIER_NAMES if t in flow_tiers and t in truth_tiers
    ]
    return bool(rows), gap_table(flow, truth, rows, "tier") if rows else ""


def confirmation_gap(result: Mapping[str, Any], results: Path, policies_dir: Path) -> tuple[bool, str, str]:
    """The pick against its true-depth recipe on the confirmation layouts: whether flown, the table, and one
    clause per condition, each a paired difference with its verdict."""
    from agents.studies.confirmation import outcome_matrices

    if not flow_costs(result):
        return False, "", ""
    matrices = outcome_matrices(
        results / "confirmation", (PICK, TRUE_DEPTH_RECIPE), result["layouts"], policies_dir
    )
    flown = {
        condition: (found[PICK], found[TRUE_DEPTH_RECIPE])
        for condition, found in matrices.items()
        if PICK in found and TRUE_DEPTH_RECIPE in found
    }
    rows = [gap_row(condition, flow, truth) for condition, (flow, truth) in flown.items()]
    sentence = "; ".join(
        f"{condition}: {row[3]}, {row[4]}" for condition, row in zip(flown, rows, strict=True)
    )
    return True, gap_table(PICK, TRUE_DEPTH_RECIPE, rows, "condition"), sentence


def _seed_status(policies_dir: Path) -> str:
    stages = [Path(config).stem for config in TRUE_DEPTH_STAGES]
    return join_words(
        [f"`{stage}` {len(shipped_seed_runs(stage, policies_dir))} of {SEEDS_WANTED}" for stage in stages]
    )


# The rise over its clean failure rate the pick must stay within at each condition: the robustness limit.
PICK_RISE_LIMIT = 0.10


def selection_values(result: Mapping[str, Any], search: Mapping[str, Any]) -> Values:
    """The search as it happened and what the fresh layouts say about the pick, worded from the numbers."""
    rises = [r for r in result["rises"] if r["agent"] == PICK]
    layouts = search["layouts"]
    return {
        "search_count": str(len(search["configs"])),
        "search_layouts": f"{len(layouts)} ({layouts[0]:,}–{layouts[-1]:,})" if layouts else "0",
        "confirmation_layouts": str(result["layouts"]),
        "confirmation_flown": bool(rises),
        "pick_standing": _pick_standing(rises),
        "first_stage": COMPARED[0],
        "first_stage_verdict": _stage_verdict(result, COMPARED[0]),
        "second_stage_shown": any(d["high"] < 0 for d in result["differences"] if d["other"] == COMPARED[0]),
        "after_the_search": join_words([f"`{name}`" for name in FLOWN_AFTER_THE_SEARCH]),
        "first_stage_readings": _stage_readings(result, COMPARED[0]),
        "plain_verdict": _stage_verdict(result, COMPARED[1]),
        "plain_readings": _stage_readings(result, COMPARED[1]),
    }


def _pick_standing(rises: Sequence[Mapping[str, Any]]) -> str:
    """Where the pick stays within :data:`PICK_RISE_LIMIT` of its clean rate (by its whole interval or by its
    point estimate only) and where it misses it."""
    limit = PICK_RISE_LIMIT
    met = [r["condition"] for r in rises if r["high"] <= limit]
    point_only = [r["condition"] for r in rises if r["rise"] <= limit < r["high"]]
    missed = [r["condition"] for r in rises if r["rise"] > limit]
    parts = [
        f"{how} at {join_words(conditions)}"
        for how, conditions in (
            ("with its whole interval", met),
            ("by point estimate only", point_only),
        )
        if conditions
    ]
    standing = f"stays within +{limit:.2f} of its clean rate {'; '.join(parts)}" if parts else ""
    if missed:
        standing += ("; it " if standing else "") + f"misses that limit at {join_words(missed)}"
    return standing


def _stage_readings(result: Mapping[str, Any], other: str) -> str:
    """The pick less ``other`` under each condition, with its interval."""
    found = [d for d in result["differences"] if d["other"] == other]
    return "; ".join(
        f"{d['condition']} {d['difference']:+.3f} [{d['low']:+.3f}, {d['high']:+.3f}]" for d in found
    )


def _stage_verdict(result: Mapping[str, Any], other: str) -> str:
    """What the differences from ``other`` say together: fewer failures everywhere, none anywhere, or mixed."""
    found = [d for d in result["differences"] if d["other"] == other]
    if found and all(d["high"] < 0 for d in found):
        return "fails less under every condition"
    if found and all(d["low"] <= 0 <= d["high"] for d in found):
        return "shows no difference under any condition"
    return "differs under some conditions only"


def _plain_values(data: BenchmarkData, results: Path, policies_dir: Path) -> Values:
    flow, truth = data.row(PLAIN_FLOW), data.row(PLAIN_TRUTH)
    clean = data.validation["clean"]
    suite_flown, suite_table = _suite_gap(results, PLAIN_FLOW, PLAIN_TRUTH, policies_dir)
    bounds = [(r["failure_low"], r["failure_high"]) for r in (flow, truth)]
    plain_test_gap = data.compare(PLAIN_FLOW, PLAIN_TRUTH)
    flow_steps, truth_steps = (data.training[a].config["total_timesteps"] for a in (PLAIN_FLOW, PLAIN_TRUTH))
    return {
        "ppo_steps": f"{flow_steps:,}",
        "oracle_steps": f"{truth_steps:,}",
        "plain_same_budget": flow_steps == truth_steps,
        "plain_test_flow": interval(flow["failure_rate"], *bounds[0]),
        "plain_test_truth": interval(truth["failure_rate"], *bounds[1]),
        "plain_test_relation": paired_reading(plain_test_gap),
        "plain_test_runs": f"{flow['runs']} and {truth['runs']}",
        "plain_validation_flow": interval(
            clean[PLAIN_FLOW].rate, clean[PLAIN_FLOW].low, clean[PLAIN_FLOW].high
        ),
        "plain_validation_truth": interval(
            clean[PLAIN_TRUTH].rate, clean[PLAIN_TRUTH].low, clean[PLAIN_TRUTH].high
        ),
        "plain_validation_layouts": str(clean[PLAIN_FLOW].episodes // clean[PLAIN_FLOW].runs),
        "plain_suite_flown": suite_flown,
        "plain_suite_table": suite_table,
    }


def _cell(matrix: np.ndarray | None) -> Cell | None:
    if matrix is None:
        return None
    return (float(matrix.mean()), *failure_interval_over_runs_and_layouts(matrix))


def gap_bars(
    data: BenchmarkData, result: Mapping[str, Any], results: Path, policies_dir: Path
) -> dict[str, list[tuple[str, Cell | None, Cell | None]]]:
    """What the figure shows, per recipe: (where, flow's failure, truth's failure), None where not flown."""
    flow, truth = data.row(PLAIN_FLOW), data.row(PLAIN_TRUTH)
    clean = data.validation["clean"]
    plain: list[tuple[str, Cell | None, Cell | None]] = [
        (
            "test, clean",
            (flow["failure_rate"], flow["failure_low"], flow["failure_high"]),
            (truth["failure_rate"], truth["failure_low"], truth["failure_high"]),
        ),
        (
            "validation, clean",
            (clean[PLAIN_FLOW].rate, clean[PLAIN_FLOW].low, clean[PLAIN_FLOW].high),
            (clean[PLAIN_TRUTH].rate, clean[PLAIN_TRUTH].low, clean[PLAIN_TRUTH].high),
        ),
    ]
    rates = {(r["condition"], r["agent"]): (r["failure"], r["low"], r["high"]) for r in result["rates"]}
    pick = [
        (
            f"fresh validation, {condition}",
            rates.get((condition, PICK)),
            rates.get((condition, TRUE_DEPTH_RECIPE)),
        )
        for condition in dict.fromkeys(r["condition"] for r in result["rates"])
    ]
    for bars, (flow_agent, truth_agent) in (
        (plain, (PLAIN_FLOW, PLAIN_TRUTH)),
        (pick, (PICK, TRUE_DEPTH_RECIPE)),
    ):
        flow_tiers, truth_tiers = (
            suite_matrices(results, a, policies_dir) for a in (flow_agent, truth_agent)
        )
        bars += [
            (f"suite, {t}", _cell(flow_tiers.get(t)), _cell(truth_tiers.get(t)))
            for t in TIER_NAMES
            if t in flow_tiers or t in truth_tiers
        ]
    return {f"`{PLAIN_FLOW}` / `{PLAIN_TRUTH}`": plain, f"the pick / {TRUE_DEPTH_RECIPE}": pick}


def flow_gap_values(
    results_dir: Path, policies_dir: Path = POLICIES_DIR, result: Mapping[str, Any] | None = None
) -> Values:
    """Every value of the flow-gap template, from the committed data under ``results_dir``; ``result``: the
    confirmation's comparison (:func:`run_confirmation`) when the caller has it already."""
    results = Path(results_dir)
    data = load_benchmark_data(results)
    if result is None:
        result = run_confirmation(results / "confirmation", report_only=True, policies_dir=policies_dir)
    confirmation_flown, confirmation_table, confirmation_sentence = confirmation_gap(
        result, results, policies_dir
    )
    suite_flown, suite_table = _suite_gap(results, PICK, TRUE_DEPTH_RECIPE, policies_dir)
    test_flown, test_table = _test_gap(data, results, policies_dir)
    values: Values = {
        **leaderboard_values(data),
        **reactive_gap_values(data),
        **validation_values(data),
        **flow_gap_target_values(data),
        **_plain_values(data, results, policies_dir),
        **selection_values(result, search_record(results / "ablation")),
        "pick": PICK,
        "pick_name": display_name(PICK),
        "truth_recipe": TRUE_DEPTH_RECIPE,
        "truth_seed_status": _seed_status(policies_dir),
        "truth_train_commands": "\n".join(
            f"flownav {step} --config {config} --seeds 0-{SEEDS_WANTED - 1}{options} --ship"
            for config in TRUE_DEPTH_STAGES
            for step, options in (("train", " --parallel 2"), ("select", ""))
        ),
        "truth_confirmation_flown": confirmation_flown,
        "truth_confirmation_table": confirmation_table,
        "truth_confirmation_sentence": confirmation_sentence,
        "truth_test_flown": test_flown,
        "truth_test_table": test_table,
        "truth_suite_flown": suite_flown,
        "truth_suite_table": suite_table,
        "suite_version": SUITE_VERSION,
        "confirmation_layouts_wanted": str(CONFIRMATION_LAYOUTS),
    }
    return values


def write_flow_gap(
    results_dir: Path, out: Path, command: str, policies_dir: Path = POLICIES_DIR
) -> list[str]:
    """Write ``out/flow_gap.md`` and its figure ``flow_gap.png`` from the committed data under ``results_dir``.

    Args:
        results_dir: a folder with the layout of ``results/`` (episodes, ablations, confirmation flights).
        out: the output folder (created); nothing else is written.
        command: the command line the report names on its "Generated" line.
        policies_dir: where the shipped training seeds are (the runs the flights are matched against).

    Returns:
        The report's lines.

    Raises:
        FileNotFoundError: a missing input, named in one line.
        ValueError: an unwritable ``out``, or data the report cannot be worded from.
    """
    results = Path(results_dir)
    result = run_confirmation(results / "confirmation", report_only=True, policies_dir=policies_dir)
    values = {**flow_gap_values(results, policies_dir, result), "generated": today(), "command": command}
    panels = gap_bars(load_benchmark_data(results), result, results, policies_dir)
    # The values include the benchmark's groups whole (leaderboard, validation, targets); the template words some.
    text = render(PACKAGE, FLOW_GAP_TEMPLATE, values)
    out = Path(out)
    check_writable_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    plot_gap(panels, out / "flow_gap.png")
    write_text_atomically(out / "flow_gap.md", text)
    return text.splitlines()
