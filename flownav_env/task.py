"""The FlowNav task beside its physics, split as dm_control splits them: :class:`~flownav_env.physics.FlowNavPhysics`
is the world (bodies, contacts, cameras, named accessors), :class:`FlowNavTask` is what the drone is asked to
do in it: the course an episode starts on, how an action commands the flight, what the agent observes, how it
is rewarded and when the episode ends. :class:`flownav_env.FlowNavEnv` runs the two, with the camera, the
sensor and the estimator in between; the time limit is the registration's (:mod:`flownav_env.limits`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TypedDict

import numpy as np

from estimator import CameraIntrinsics, DepthPoints
from estimator.histogram import SectorGrid
from flownav_env.observation import (
    assemble_observation,
    drone_state,
    observation_space,
    observed_depths,
    smoothed_near,
)
from flownav_env.physics import FlowNavPhysics
from flownav_env.privileged import privileged_observation
from flownav_env.quadrotor import velocity_command
from flownav_env.scene import LAYOUT_FUNCTIONS, material_names
from flownav_env.settings import EnvSettings

# How an episode can end, exactly one each: an episode that ends on none of the first three ran out of time.
EPISODE_OUTCOMES = ("success", "collision", "out_of_bounds", "timeout")


def episode_outcome(collision: bool, out_of_bounds: bool, success: bool) -> str:
    """The one :data:`EPISODE_OUTCOMES` entry of an episode whose last step had these flags, which may hold
    together: a collision outranks the rest (the drone touched something, wherever it was), then leaving the
    bounds (reaching the goal line out of bounds is out of bounds), then the goal; none of them is a timeout."""
    if collision:
        return "collision"
    if out_of_bounds:
        return "out_of_bounds"
    return "success" if success else "timeout"


class OutcomeInfo(TypedDict):
    """The outcome's entries of a step's (or ``reset``'s) ``info``, as :class:`StepOutcome` names them but
    ``progress``: the drone's x (m)."""

    collision: bool
    success: bool
    out_of_bounds: bool
    progress: float
    clearance: float
    min_clearance: float
    position: np.ndarray


@dataclass(frozen=True)
class StepOutcome:
    """Where a step left the drone and what that means for the episode.

    Attributes:
        collision: The drone touched an obstacle or the ground.
        success: It crossed the goal line, in bounds, without a collision.
        out_of_bounds: It is more than ``lateral_bound`` sideways of the course axis or above ``max_height``,
            without a collision. At most one of the three holds (:func:`episode_outcome`).
        position: Its world position, m.
        progress_m: Metres gained toward the goal line this step.
        clearance: Distance from its centre to the nearest capsule surface, m (inf without capsules).
        min_clearance: The least clearance of the episode so far, m.
    """

    collision: bool
    success: bool
    out_of_bounds: bool
    position: np.ndarray
    progress_m: float
    clearance: float
    min_clearance: float

    @property
    def terminated(self) -> bool:
        """Whether the episode ends here (a collision, the goal, or out of bounds)."""
        return self.collision or self.success or self.out_of_bounds

    def info(self) -> OutcomeInfo:
        """The step's ``info`` entries of the outcome (``progress`` is the drone's x, m)."""
        return {
            "collision": self.collision,
            "success": self.success,
            "out_of_bounds": self.out_of_bounds,
            "progress": float(self.position[0]),
            "clearance": self.clearance,
            "min_clearance": self.min_clearance,
            "position": self.position,
        }


def reward_terms(
    settings: EnvSettings,
    progress_m: float,
    success: bool,
    failed: bool,
    action: np.ndarray,
    clearance_m: float,
) -> dict[str, float]:
    """The reward terms of one step (``FlowNavEnv``'s Rewards section gives the formula).

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


class FlowNavTask:
    """What FlowNav asks of the drone, and the per-episode state of asking it (goal line, least clearance, the
    last observation for ``near_smoothing``).

    Its methods take the env's current settings: sensor and course settings change between episodes
    (``FlowNavEnv.set_sensor``, ``set_course``). What fixes the observation's shape (sectors, bins, keys) is
    read once here, with the sector grid every step's observation bins its points into.

    Args:
        settings: The env's settings at construction.
        intrinsics: The forward camera's pinhole model (its image size sets the sectors).
    """

    def __init__(self, settings: EnvSettings, intrinsics: CameraIntrinsics) -> None:
        self.observation_space = observation_space(settings)
        self.grid = SectorGrid(intrinsics.image_size, settings.histogram_sectors, settings.depth_bin_edges)
        self.goal_x = settings.field_length
        self.min_clearance = math.inf
        self._materials = len(material_names())
        self._observed: dict[str, np.ndarray] | None = None  # the last observation, for near_smoothing

    def initialize_episode(
        self, physics: FlowNavPhysics, settings: EnvSettings, rng: np.random.Generator
    ) -> None:
        """Lay out a course drawn from ``rng`` (capsule positions, then their materials) and put the drone at
        the start: x = 0, y = 0, ``flight_height``, heading +x, moving at ``forward_speed``, in hover trim."""
        positions, self.goal_x = LAYOUT_FUNCTIONS[settings.layout](rng, settings.layout_params())
        physics.place_obstacles(positions, rng.integers(self._materials, size=len(positions)))
        start = np.array([0.0, 0.0, settings.flight_height])
        physics.reset_drone(start, 0.0, np.array([settings.forward_speed, 0.0, 0.0]))
        self.min_clearance = physics.obstacle_clearance()
        self._observed = None

    def start_info(self, physics: FlowNavPhysics) -> OutcomeInfo:
        """The outcome entries of ``reset``'s ``info``: nothing has happened yet; the drone is at its start."""
        clearance = self.min_clearance
        return {
            "collision": False,
            "success": False,
            "out_of_bounds": False,
            "progress": 0.0,
            "clearance": clearance,
            "min_clearance": clearance,
            "position": physics.position(),
        }

    @staticmethod
    def command(
        physics: FlowNavPhysics, settings: EnvSettings, action: np.ndarray
    ) -> tuple[np.ndarray, float]:
        """The velocity controller's targets for a checked action: world velocity (m/s; ``forward_speed``
        along the heading, sideways and vertical scaled by their largest speeds) and yaw rate (rad/s)."""
        speeds = (settings.forward_speed, settings.max_lateral_speed, settings.max_vertical_speed)
        return velocity_command(physics.yaw(), action, *speeds), -action[2] * settings.max_yaw_rate

    def observe(
        self, physics: FlowNavPhysics, settings: EnvSettings, points: DepthPoints, true_depth: np.ndarray
    ) -> dict[str, np.ndarray]:
        """The observation of the estimator's ``points`` (their depths per ``obs_source``; ``true_depth`` is
        empty where it was not ray-cast) and of the drone's state, ``nearness``/``approach`` smoothed over the
        episode's frames."""
        depth, counted = observed_depths(settings.obs_source, points, true_depth)
        raw = assemble_observation(settings, self.grid, drone_state(physics), points, depth, counted)
        if settings.observe_layout:
            raw |= privileged_observation(physics, settings, self.goal_x)
        self._observed = smoothed_near(raw, self._observed, settings.near_smoothing)
        return self._observed

    def outcome(
        self, physics: FlowNavPhysics, settings: EnvSettings, x_before: float, collision: bool
    ) -> StepOutcome:
        """Where the step that started at x = ``x_before`` left the drone: goal, bounds, progress, clearance."""
        position = physics.position()
        clearance = physics.obstacle_clearance()
        self.min_clearance = min(self.min_clearance, clearance)
        outside = bool(abs(position[1]) > settings.lateral_bound or position[2] > settings.max_height)
        ended = episode_outcome(collision, outside, bool(position[0] >= self.goal_x))
        success, out_of_bounds = ended == "success", ended == "out_of_bounds"
        progress = float(position[0] - x_before)
        return StepOutcome(
            collision, success, out_of_bounds, position, progress, clearance, self.min_clearance
        )

    @staticmethod
    def reward(settings: EnvSettings, outcome: StepOutcome, action: np.ndarray) -> dict[str, float]:
        """The step's reward terms (:func:`reward_terms`) for its outcome and checked action."""
        failed = outcome.collision or outcome.out_of_bounds
        return reward_terms(settings, outcome.progress_m, outcome.success, failed, action, outcome.clearance)
