"""FlowNav's per-step reward, term by term (each term also goes to ``info``). Pure arithmetic on what one step
produced; the weights are env settings (``FlowNavEnv``'s Rewards section gives the formula)."""

from __future__ import annotations

import numpy as np

from flownav_env.settings import EnvSettings


def reward_terms(
    settings: EnvSettings,
    progress_m: float,
    success: bool,
    failed: bool,
    action: np.ndarray,
    clearance_m: float,
) -> dict[str, float]:
    """The reward terms of one step.

    Args:
        settings: the env's settings (the weights).
        progress_m: metres gained toward the goal line this step.
        success: the goal was reached.
        failed: a collision, or the drone left the bounds.
        action: the clipped action.
        clearance_m: distance from the drone's centre to the nearest capsule surface (inf without capsules).

    Returns:
        ``reward_progress``, ``reward_success``, ``reward_collision``, ``reward_control`` and
        ``reward_clearance``; the step's reward is their sum.
    """
    # Clearance shaping: a penalty growing linearly from 0 at safe_clearance to the full weight at contact,
    # so passing close costs something before a collision does, and open space costs nothing.
    closeness = max(0.0, 1.0 - clearance_m / settings.safe_clearance)
    return {
        "reward_progress": settings.progress_weight * progress_m,
        "reward_success": settings.success_bonus * float(success),
        "reward_collision": -settings.collision_penalty * float(failed),
        "reward_control": -settings.control_cost_weight * float(action @ action),
        "reward_clearance": -settings.clearance_weight * closeness,
    }
