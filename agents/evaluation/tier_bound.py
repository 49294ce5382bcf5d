"""Each tier's bound: how often the privileged planner fails on the tier's layouts, and why, by a check that
shares none of the planner's code (:func:`agents.policies.planner_feasibility.corridor_exists`): a layout with no
collision-free corridor at the tier's speed and the drone's limits is infeasible, any other failure the planner's
own miss. The gap between a tier's best ranked agent and the planner is what is left to learn.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any, TypedDict

import gymnasium as gym
import numpy as np

from agents.analysis.paired import Comparison, compare
from agents.analysis.statistics import wilson_interval
from agents.policies.planner_feasibility import corridor_exists
from flownav_env.privileged import COURSE_INFO_FIELDS
from flownav_env.tiers import SUITE_VERSION, tier

BOUND_AGENT = "planner"
# The layout does not depend on the camera: the smallest frames make the check cheap.
_CHECK_FRAME: dict[str, Any] = {"camera_width": 32, "camera_height": 24}


class TierBound(TypedDict):
    """A tier's bound (:func:`tier_bound`): the planner's failure rate with its 95 % interval (Wilson), its failed
    layouts split into infeasible ones and its own misses, the infeasible share of all layouts, and the tier's
    best ranked agent with its failure rate and its paired gap to the planner."""

    planner_failure: float
    planner_low: float
    planner_high: float
    failed: int
    infeasible: int
    misses: int
    infeasible_share: float
    best: str
    best_failure: float
    gap: Comparison


def layout_is_feasible(tier_name: str, seed: int, version: str = SUITE_VERSION) -> bool:
    """Whether the layout of ``seed`` on ``tier_name`` of suite ``version`` has a collision-free corridor to the
    goal line at the tier's forward speed and the drone's lateral speed limit (read from the env's privileged
    keys)."""
    spec = tier(tier_name, version)
    env = gym.make(spec.env_id, observe_layout=True, **_CHECK_FRAME)
    try:
        observation, _ = env.reset(seed=seed)
    finally:
        env.close()
    course = dict(zip(COURSE_INFO_FIELDS, (float(v) for v in observation["course"]), strict=True))
    return corridor_exists(
        observation["layout"],
        goal_x=course["goal_x"],
        forward_speed=course["forward_speed"],
        max_lateral_speed=course["max_lateral_speed"],
        lateral_bound=course["lateral_bound"],
        drone_radius=course["drone_radius"],
    )


def tier_bound(
    tier_name: str,
    planner: np.ndarray,
    best_name: str,
    best: np.ndarray,
    layouts: Sequence[int],
    feasible: Callable[[str, int], bool] = layout_is_feasible,
) -> TierBound:
    """The bound's values for one tier: the planner's failures (1, layouts) on ``layouts``, each failed layout
    classified, and the best ranked agent against the planner, paired by layout.

    Args:
        feasible: ``(tier_name, seed) -> bool``, the independent corridor check (a stand-in in tests).
    """
    failed = [seed for seed, value in zip(layouts, planner[0], strict=True) if value]
    infeasible = [seed for seed in failed if not feasible(tier_name, seed)]
    low, high = wilson_interval(len(failed), len(layouts))
    return {
        "planner_failure": float(planner.mean()),
        "planner_low": low,
        "planner_high": high,
        "failed": len(failed),
        "infeasible": len(infeasible),
        "misses": len(failed) - len(infeasible),
        "infeasible_share": len(infeasible) / len(layouts),
        "best": best_name,
        "best_failure": float(best.mean()),
        "gap": compare(best_name, best, BOUND_AGENT, planner),
    }


def suite_bounds(
    failures: Mapping[str, Mapping[str, np.ndarray]],
    bests: Mapping[str, str],
    layouts: Sequence[int],
    version: str = SUITE_VERSION,
) -> dict[str, TierBound]:
    """:func:`tier_bound` for each tier the planner has flown in full, against that tier's best ranked agent
    (the layouts of suite ``version``)."""

    def feasible(tier_name: str, seed: int) -> bool:
        return layout_is_feasible(tier_name, seed, version)

    return {
        name: tier_bound(name, matrices[BOUND_AGENT], bests[name], matrices[bests[name]], layouts, feasible)
        for name, matrices in failures.items()
        if BOUND_AGENT in matrices and name in bests
    }
