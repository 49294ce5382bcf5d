"""Any agent's robustness curves: failure against each sensor error, the sweep's own quantities
(``flownav score --robustness``).

An agent flies the sweep's clean cell and every level of each sensor factor of ``configs/sweep.yaml`` (the task
factors, speed, density and brightness, change the course rather than the sensor and are left to the suite's
tiers), on the sweep's own test layouts, so its curves sit beside the published agents' in ``results/sweep.md``.
A learned agent flies layout i with its training seed i mod the seed count, as in the sweep. Per factor and side
of the neutral level the summary gives:

* the **area**: the failure rate averaged over the factor's flown range, the clean cell at its neutral level
  included (trapezoids in the factor's own units, divided by the range's width): one number per curve, 0 for an
  agent no level touches, 1 for one that always fails;
* the **breaking level**: the first level whose failure interval lies wholly above the clean cell's, the
  sweep's definition (:func:`agents.studies.error_analysis.tolerance_table`), with the failure there.

Episodes go to ``<out>/robustness_episodes.csv`` (resumable, keyed like the sweep's); the curves to
``robustness.csv``, the summary to ``robustness_summary.csv``, and a panel per factor to ``robustness.png``.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from agents.analysis.dose_response import TASK_FACTORS
from agents.analysis.episode_record import EpisodeRow
from agents.analysis.records import read_records
from agents.analysis.statistics import CellSummary, summarise
from agents.common.folders import check_writable_folder, write_text_atomically
from agents.common.locations import REPO_ROOT
from agents.common.yaml_config import load_config
from agents.evaluation.episode_tasks import rows_of
from agents.evaluation.runner import execute
from agents.evaluation.sweep import ALL_SEEDS, SweepConfig, build_tasks, pool_every_seed
from agents.evaluation.sweep_summary import SUMMARY_FIELDS
from agents.pages.sweep_report import plot_collision_vs_error
from agents.pages.wording import render_report
from agents.policies.agent_limits import DEFAULT_STEP_TIMEOUT_S, AgentLimits
from agents.policies.base import is_learned, split_agent_name
from agents.studies.error_analysis import neutral_level, tolerance_table

SWEEP_CONFIG = REPO_ROOT / "configs" / "sweep.yaml"
EPISODES_CSV = "robustness_episodes.csv"
SUMMARY_COLUMNS = [
    "agent",
    "factor",
    "side",
    "levels",
    "area",
    "clean_failure",
    "breaking_level",
    "breaking_failure",
    "worst_level",
    "worst_failure",
]


def sensor_levels(config: SweepConfig, factors: str | Sequence[str] | None = None) -> dict[str, list[float]]:
    """The sweep's sensor factors and their levels, in the config's order; ``factors`` (comma-separated or a
    list) keeps a subset.

    Raises:
        ValueError: a name that is not one of the sweep's sensor factors.
    """
    sensor = {name: levels for name, levels in config.factors.items() if name not in TASK_FACTORS}
    if factors is None:
        return sensor
    names = [name.strip() for name in factors.split(",")] if isinstance(factors, str) else list(factors)
    names = [name for name in names if name]
    for name in names:
        if name not in sensor:
            raise ValueError(
                f"--factors: {name!r} is not one of the sweep's sensor factors ({', '.join(sensor)})"
            )
    if not names:
        raise ValueError(f"--factors: give at least one of {', '.join(sensor)}")
    return {name: sensor[name] for name in sensor if name in names}


def curve_area(points: Sequence[tuple[float, float]]) -> float:
    """The failure rate averaged over a curve's range: trapezoids over (level, failure) points, sorted by level,
    divided by the range's width (the one point's failure when there is no width)."""
    ordered = sorted(points)
    levels = np.array([level for level, _ in ordered], float)
    failures = np.array([failure for _, failure in ordered], float)
    width = levels[-1] - levels[0]
    if width <= 0:
        return float(failures.mean())
    return float(np.sum((failures[1:] + failures[:-1]) / 2 * np.diff(levels)) / width)


def summarise_curves(table: Sequence[CellSummary], rows: Sequence[EpisodeRow]) -> list[dict[str, object]]:
    """Per agent, factor and side of the neutral level: the area under its curve and where it breaks (a CSV
    row of :data:`SUMMARY_COLUMNS`)."""
    summary = []
    for entry in tolerance_table(rows):
        agent, factor = entry["agent"], entry["factor"]
        rates = {
            float(r["level"]): r["failure_rate"]
            for r in table
            if r["agent"] == agent and r["factor"] == factor and float(r["level"]) in entry["levels"]
        }
        points = [(neutral_level(factor), entry["clean_failure"]), *rates.items()]
        found = {**entry, "levels": len(entry["levels"]), "area": curve_area(points)}
        summary.append({column: found[column] for column in SUMMARY_COLUMNS})
    return summary


def _csv_text(columns: Sequence[str], table: Sequence[Mapping[str, object]]) -> str:
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=list(columns), lineterminator="\n", extrasaction="ignore")
    writer.writeheader()
    for row in table:
        writer.writerow(
            {k: round(v, 4) if isinstance(v, float) else ("" if v is None else v) for k, v in row.items()}
        )
    return text.getvalue()


def robustness_cells(
    factors: str | Sequence[str] | None = None, layouts: int | None = None, config_path: Path = SWEEP_CONFIG
) -> SweepConfig:
    """The sweep config of the curves, without agents: the sensor factors asked for and the layouts per cell;
    a command checks its options with it before it flies anything.

    Raises:
        ValueError: an unknown factor, or a layout count outside [1, the sweep's].
    """
    config = load_config(config_path, SweepConfig)
    if layouts is not None and (isinstance(layouts, bool) or not 1 <= layouts <= config.episodes):
        raise ValueError(f"--robustness-layouts must be in [1, {config.episodes}], got {layouts}")
    return replace(
        config, agents=[], factors=sensor_levels(config, factors), episodes=layouts or config.episodes
    )


def robustness(
    agent: str,
    out: str | Path,
    *,
    factors: str | Sequence[str] | None = None,
    layouts: int | None = None,
    policy: str | None = None,
    trust_pickle: bool = False,
    workers: int = 1,
    backend: str = "local",
    address: str | None = None,
    config_path: Path = SWEEP_CONFIG,
    agent_limits: AgentLimits | None = None,
    step_timeout_s: float = DEFAULT_STEP_TIMEOUT_S,
) -> list[dict[str, object]]:
    """Fly ``agent``'s robustness curves into ``out`` and return their summary (:data:`SUMMARY_COLUMNS`).

    Args:
        agent: a resolved agent name (:func:`agents.evaluation.suite.resolve_agent`): a FlowNav agent, an outside
            agent's spec or a stable-baselines3 model's; a learned FlowNav agent flies its shipped seeds.
        out: output folder; calling again resumes.
        factors: a subset of the sweep's sensor factors (default: all of them).
        layouts: the first this many of the sweep's layouts per cell (default: the sweep's count).
        policy: a learned agent's policy file, if not the shipped ones; trust_pickle: allow unpickling it.
        workers, backend, address: where episodes fly, as for the sweep.
        config_path: the sweep config whose factors, levels and layouts are used.
        agent_limits, step_timeout_s: an outside agent's memory, CPU time and sandbox, and the most its
            ``predict`` may take, as ``flownav score``'s.

    Raises:
        ValueError: an unknown factor, a layout count outside [1, the sweep's], or an unwritable ``out``.
    """
    config = robustness_cells(factors, layouts, config_path)
    # A learned agent named without a seed flies its shipped seeds in turn, as the sweep flies it.
    shipped = policy is None and is_learned(agent) and split_agent_name(agent)[1] is None
    name = f"{agent}{ALL_SEEDS}" if shipped else agent
    config = replace(config, agents=[name])
    out = Path(out)
    check_writable_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    tasks = build_tasks(config, [name])
    if policy is not None or trust_pickle:
        tasks = [replace(task, policy=policy or task.policy, trust_pickle=trust_pickle) for task in tasks]
    csv_path = out / EPISODES_CSV
    execute(
        tasks,
        csv_path,
        backend=backend,
        workers=workers,
        address=address,
        description=f"robustness {agent}",
        step_timeout_s=step_timeout_s,
        agent_limits=agent_limits,
    )
    rows = pool_every_seed(rows_of(tasks, read_records(csv_path)))
    table = summarise(rows)
    write_text_atomically(out / "robustness.csv", _csv_text(SUMMARY_FIELDS, table))
    plot_collision_vs_error(table, list(config.factors), out / "robustness.png")
    summary = summarise_curves(table, rows)
    write_text_atomically(out / "robustness_summary.csv", _csv_text(SUMMARY_COLUMNS, summary))
    return summary


@dataclass(frozen=True)
class RobustnessSummaryValues:
    """What ``robustness_summary.md`` words (``templates/robustness_summary.md.j2``): a row per curve."""

    summary: Sequence[Mapping[str, object]]


def summary_lines(summary: Sequence[Mapping[str, object]]) -> list[str]:
    """The summary as a Markdown table, a row per curve."""
    return [render_report("robustness_summary.md.j2", RobustnessSummaryValues(summary)).rstrip("\n")]
