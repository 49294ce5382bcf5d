"""Which published suite episodes re-fly bit for bit, and on which CPU (``flownav reflight``).

A sample of an agent's published episodes is flown again here, with the code of this checkout, and each is
compared with its row: **identical** when every measured number is equal to the last bit, **same outcome** when it
ends the same way. A learned policy's forward pass sums in an order its CPU's vector instructions choose, and
differences in the last bits grow in closed loop, so the rows record the CPU each re-flight ran on and ``suite.md``
says what re-flew and where; a row flown by a process with uncommitted changes shows here whether they changed
anything.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from agents.analysis.episode_record import MEASURED_FIELDS, EpisodeRow, row_outcome
from agents.analysis.reflights import Reflight
from agents.common.machine import cpu_signature
from agents.evaluation.episode_tasks import EpisodeTask
from agents.evaluation.progress import episode_progress
from agents.evaluation.runner import FlightCache, run_task
from agents.evaluation.suite import agent_runs, suite_rows, suite_tasks


def _differs(recorded: EpisodeRow, again: dict[str, object]) -> str:
    """The measured numbers of ``again`` that are not ``recorded``'s to the last bit, comma-joined (NaN equals NaN;
    a column the row predates is not compared)."""
    names = []
    for name in MEASURED_FIELDS:
        said = recorded.get(name)
        if said is None:
            continue
        now = again[name]
        if not (said == now or (isinstance(said, float) and np.isnan(said) and np.isnan(float(str(now))))):
            names.append(name)
    return ",".join(names)


def pick_episodes(
    agent: str, tiers: Sequence[str], episodes: int, published: Path, seed: int
) -> list[tuple[EpisodeTask, EpisodeRow]]:
    """``episodes`` of ``agent``'s published episodes per tier, drawn with ``seed``, each with its row."""
    draw = np.random.default_rng(seed)
    chosen = []
    runs = {agent: agent_runs(agent)}
    for name in tiers:
        tasks = suite_tasks(runs, [name])
        recorded = {(row["agent"], int(row["seed"])): row for row in suite_rows(tasks, published)}
        pairs = [
            (task, recorded[(task.agent, task.seed)]) for task in tasks if (task.agent, task.seed) in recorded
        ]
        if not pairs:
            raise ValueError(
                f"{published} holds no episodes of {agent} on tier {name}: fly it first (flownav suite)"
            )
        picks = draw.choice(len(pairs), size=min(episodes, len(pairs)), replace=False)
        chosen += [pairs[index] for index in sorted(picks)]
    return chosen


def reflight(chosen: Sequence[tuple[EpisodeTask, EpisodeRow]], agent: str) -> list[Reflight]:
    """Fly each chosen episode again here and compare it with its row."""
    cpu = cpu_signature()
    cache = FlightCache()
    found = []
    progress = episode_progress([task for task, _ in chosen], f"reflight {agent}")
    try:
        for task, row in chosen:
            again = dataclasses.asdict(run_task(task, cache))
            found.append(
                Reflight(
                    agent,
                    task.agent,
                    str(task.tier),
                    task.seed,
                    cpu,
                    str(row.get("code_version") or ""),
                    _differs(row, again),
                    row_outcome(row) == row_outcome(again),
                )
            )
            progress.update(task.factor)
    finally:
        progress.close()
        cache.clear()
    return found
