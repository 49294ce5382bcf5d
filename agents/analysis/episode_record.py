"""What one episode came to, as the analysis reads it: the record (one CSV row) and its one outcome."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import TypedDict

from agents.common.agent_table import AGENTS, base_agent_name

# How an episode can end, exactly one each: an episode that ends on none of the first three ran out of time.
# The env's own rule (flownav_env.task.EPISODE_OUTCOMES, episode_outcome), restated here so that reading records
# needs no simulator; tests/agents/analysis/test_episode_record.py checks that the two agree.
EPISODE_OUTCOMES = ("success", "collision", "out_of_bounds", "timeout")


def episode_outcome(collision: bool, out_of_bounds: bool, success: bool) -> str:
    """The one :data:`EPISODE_OUTCOMES` entry of an episode whose last step had these flags: a collision
    outranks the rest, then leaving the bounds, then the goal; none of them is a timeout."""
    if collision:
        return "collision"
    if out_of_bounds:
        return "out_of_bounds"
    return "success" if success else "timeout"


def row_outcome(row: Mapping[str, object]) -> str:
    """The one way the episode of a row (read, or a record as a mapping) ended, by :func:`episode_outcome`."""
    return episode_outcome(bool(row["collision"]), bool(row["out_of_bounds"]), bool(row["success"]))


@dataclass
class EpisodeRecord:
    """What one episode came to, and what defined it; one CSV row.

    The identity fields (``env_id`` to ``code_version``) are filled in by the runner from the task that flew
    the episode, so that a resumed run can tell an episode flown with other settings from its own.
    ``env_kwargs`` and ``agent_params`` are canonical JSON (``agent_params``: every parameter of a reactive
    agent, defaults included, :func:`~agents.policies.agent_parameters`); ``policy_sha256`` is the learned policy file's
    content hash ("" for reactive agents). ``code_version`` is recorded for provenance only: resuming does not
    compare it, or every commit would fly every episode again.

    Depth quality, over the steps with ground truth: ``median_depth_error`` is the median of the per-step
    median relative errors, ``mean_depth_outlier_share`` the mean per-step share of valid depths off by more
    than half (``estimator.accuracy.OUTLIER_RELATIVE_ERROR``); NaN when no step had ground truth.

    The fields' order is the CSV's column order. How files written by earlier code, without some of these
    columns, are read and resumed is the reader's business (:mod:`agents.analysis.earlier_rows`).
    """

    agent: str
    factor: str
    level: float
    seed: int
    collision: bool
    success: bool
    out_of_bounds: bool
    truncated: bool
    progress_m: float
    time_s: float
    steps: int
    min_clearance_m: float
    path_length_m: float
    mean_points_valid: float
    median_depth_error: float
    episode_return: float
    env_id: str = ""
    env_kwargs: str = ""
    agent_params: str = ""
    policy_sha256: str = ""
    code_version: str = ""
    mean_depth_outlier_share: float = math.nan
    # The benchmark suite's version (flownav_env.tiers.SUITE_VERSION) for episodes of the suite, else "".
    suite_version: str = ""
    # The farthest the drone went sideways of the course axis (m): whether it left the capsule field for the
    # free lane beside it (agents/evaluation/lane.py); NaN when not measured.
    max_abs_lateral_m: float = math.nan
    # How the agent was kept apart from the scorer (agents.policies.agent_limits: "sandbox", "process, no
    # sandbox"); "" for FlowNav's own agents, which fly in the scoring process.
    isolation: str = ""
    # The CPU the episode flew on, vendor and widest vector instruction set (agents.common.machine.cpu_signature):
    # a learned policy's floats, and so its closed-loop episodes, differ between them.
    cpu: str = ""


# The numbers an episode's flight measured (the other fields say what flew it, where, and how it ended).
MEASURED_FIELDS = tuple(
    item.name
    for item in fields(EpisodeRecord)
    if item.type in ("float", "int") and item.name not in ("level", "seed")
)


class EpisodeRow(TypedDict):
    """One row of an episodes CSV as read (:func:`agents.analysis.records.read_records`): the fields of
    :class:`EpisodeRecord`, typed, and None where the file predates the column (unknown:
    :func:`agents.analysis.earlier_rows.upgrade_row`). The fields are written out again because mypy reads a
    TypedDict's keys, like a dataclass's fields, only from the class's own body; a test keeps the two in step,
    names, order and types."""

    agent: str
    factor: str
    level: float
    seed: int
    collision: bool
    success: bool
    out_of_bounds: bool
    truncated: bool
    progress_m: float
    time_s: float
    steps: int
    min_clearance_m: float
    path_length_m: float
    mean_points_valid: float
    median_depth_error: float
    episode_return: float
    env_id: str | None
    env_kwargs: str | None
    agent_params: str | None
    policy_sha256: str | None
    code_version: str | None
    mean_depth_outlier_share: float | None
    suite_version: str | None
    max_abs_lateral_m: float | None
    isolation: str | None
    cpu: str | None


class PooledRow(EpisodeRow, total=False):
    """An episode row pooled over training runs: ``agent`` names the pool (``ppo_flow`` or ``ppo_flow@all``),
    ``run`` the run that flew it (``ppo_flow@3``; :data:`~agents.analysis.statistics.RUN_KEY`)."""

    run: str


def is_flow_agent(row: Mapping[str, object]) -> bool:
    """Whether the episode's agent steered by the estimator's depths (not an oracle's true depths, and not an
    agent blind to the histogram): its recorded ``obs_source`` where the row has settings (a rule may be flown
    on true depths), else what ``configs/agents.yaml`` says the agent sees.

    Raises:
        ValueError: an agent neither in the table nor with recorded settings (``env_kwargs``).
    """
    agent = str(row["agent"])
    entry = AGENTS.get(base_agent_name(agent))
    if entry is not None and entry.sees == "nothing":
        return False
    settings = str(row.get("env_kwargs") or "")
    if settings:
        return bool(json.loads(settings).get("obs_source", "flow") == "flow")
    if entry is None:
        raise ValueError(
            f"cannot tell whether {agent!r} steers by flow: it is not in configs/agents.yaml and its row "
            "records no env_kwargs"
        )
    return entry.sees == "flow"
