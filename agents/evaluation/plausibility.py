"""Whether an episode's record could have been flown: checked before it is recorded, so that a state changed
from outside the physics (a drone moved by writing into the simulator's memory) never becomes a row.

Each check compares what the scorer itself measured with what the settings allow: the drone's fastest step
against the fastest it can be commanded to fly, its progress and path against the time flown, and the time
against the steps taken.
"""

from __future__ import annotations

import math

from agents.analysis.episode_record import EpisodeRecord
from flownav_env.settings import EnvSettings

# How far past the fastest commanded speed a step may go: the controller overshoots a command briefly, far
# less than this.
SPEED_MARGIN = 2.0
# Rounding allowed in comparisons of times and distances (s, m).
TOLERANCE = 1e-6


def speed_bound(settings: EnvSettings) -> float:
    """The fastest (m/s) a drone flown with ``settings`` can plausibly move: :data:`SPEED_MARGIN` times its fastest
    commanded speed, forward, sideways and vertically at once."""
    commanded = math.hypot(settings.forward_speed, settings.max_lateral_speed, settings.max_vertical_speed)
    return SPEED_MARGIN * commanded


def implausibility(record: EpisodeRecord, settings: EnvSettings, fastest_step_m: float) -> str:
    """Why ``record`` cannot have been flown with ``settings`` (its fastest step ``fastest_step_m`` long), in
    words; "" when it can."""
    bound = speed_bound(settings)
    frame = 1.0 / settings.frame_rate
    if record.steps < 0 or not math.isclose(record.time_s, record.steps * frame, abs_tol=TOLERANCE):
        return f"{record.steps} steps at {settings.frame_rate:g} Hz are not its {record.time_s:g} s"
    if fastest_step_m > bound * frame + TOLERANCE:
        return (
            f"the drone moved {fastest_step_m:.2f} m in one frame of {frame:g} s, faster than the {bound:.2f} m/s "
            "it can fly"
        )
    reach = bound * record.time_s + TOLERANCE
    if record.progress_m > reach:
        return f"{record.progress_m:.2f} m of progress in {record.time_s:g} s is faster than {bound:.2f} m/s"
    if record.path_length_m > reach:
        return f"a path of {record.path_length_m:.2f} m in {record.time_s:g} s is faster than {bound:.2f} m/s"
    return ""
