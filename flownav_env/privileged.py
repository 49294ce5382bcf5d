"""Observation keys no sensor gives, for privileged reference agents only (``observe_layout=True``): the capsule
layout, the course's geometry and limits, the drone's true state, and the camera's true pose with what the
observation's histogram makes of its image (its horizontal intrinsics and depth bin edges), from which a
reference can work out which capsules the camera sees and how the histogram resolves them.

A tier never shows them to a ranked agent: ``flownav_env.tiers.PRIVILEGED_SETTING_VALUES`` lists the setting,
so the suite refuses it for an agent not declared privileged. The keys are read from the physics and the task's
goal line each step; they are ground truth, with no sensor error whatever the tier's sensor settings.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from gymnasium import spaces

from flownav_env.scene import LayoutParams

if TYPE_CHECKING:
    from flownav_env.physics import FlowNavPhysics
    from flownav_env.settings import EnvSettings

# The scene's capsule pool: no layout places more (each layout function caps itself at it), so the padded
# layout array always holds the whole course.
MAX_CAPSULES = LayoutParams().max_obstacles
# Columns of the ``layout`` key: world x and y of a capsule's axis and its radius (m).
LAYOUT_COLUMNS = ("x", "y", "radius")
TRUE_STATE_FIELDS = (
    "x",
    "y",
    "z",
    "velocity_x",
    "velocity_y",
    "velocity_z",
    "roll",
    "pitch",
    "yaw",
    "roll_rate",
    "pitch_rate",
    "yaw_rate",
)
COURSE_INFO_FIELDS = (
    "goal_x",
    "lateral_bound",
    "max_height",
    "forward_speed",
    "max_lateral_speed",
    "max_vertical_speed",
    "max_yaw_rate",
    "drone_radius",
    "frame_rate",
)
# Columns of the ``camera`` key: the camera's true world position (m), its world-from-camera rotation in the
# estimator's OpenCV axes (x right, y down, z forward) row by row, and its horizontal intrinsics: focal length and
# principal point along the image's width, and that width (px).
CAMERA_FIELDS = (
    "x",
    "y",
    "z",
    *(f"r{row}{column}" for row in range(3) for column in range(3)),
    "fx",
    "cx",
    "width",
)
# Bounds wide enough never to bind on a course the settings allow (field_length <= 200 m, lateral_bound <=
# 100 m, speeds <= 5 m/s); they only keep a tumbling crash inside the declared space.
POSITION_LIMIT_M = 1000.0
SPEED_LIMIT_M_S = 50.0
RATE_LIMIT_RAD_S = 100.0
_STATE_HIGH = np.array(
    [POSITION_LIMIT_M] * 3 + [SPEED_LIMIT_M_S] * 3 + [math.pi, math.pi / 2, math.pi] + [RATE_LIMIT_RAD_S] * 3,
    np.float32,
)
# Pixels and focal lengths (px) above any image the settings allow (camera_width <= 1280, fov >= 10 deg).
PIXEL_LIMIT = 1.0e5
_CAMERA_LOW = np.array([-POSITION_LIMIT_M] * 3 + [-1.0] * 9 + [0.0, -PIXEL_LIMIT, 0.0], np.float32)
_CAMERA_HIGH = np.array([POSITION_LIMIT_M] * 3 + [1.0] * 9 + [PIXEL_LIMIT] * 3, np.float32)
PRIVILEGED_KEYS = ("layout", "layout_mask", "true_state", "course", "camera", "depth_bin_edges")


def privileged_spaces(settings: EnvSettings) -> dict[str, spaces.Box]:
    """The boxes of the privileged keys (:data:`PRIVILEGED_KEYS`), as ``observe_layout=True`` adds them to an env
    with ``settings`` (``depth_bin_edges`` holds as many edges as they set)."""
    return {
        "layout": spaces.Box(
            -POSITION_LIMIT_M, POSITION_LIMIT_M, (MAX_CAPSULES, len(LAYOUT_COLUMNS)), np.float32
        ),
        "layout_mask": spaces.Box(0.0, 1.0, (MAX_CAPSULES,), np.float32),
        "true_state": spaces.Box(-_STATE_HIGH, _STATE_HIGH, dtype=np.float32),
        "course": spaces.Box(0.0, POSITION_LIMIT_M, (len(COURSE_INFO_FIELDS),), np.float32),
        "camera": spaces.Box(_CAMERA_LOW, _CAMERA_HIGH, dtype=np.float32),
        "depth_bin_edges": spaces.Box(0.0, POSITION_LIMIT_M, (len(settings.depth_bin_edges),), np.float32),
    }


def capsule_layout(positions: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """The ``layout`` (MAX_CAPSULES, 3) and ``layout_mask`` (MAX_CAPSULES,) of capsules at ``positions`` (N, 2).

    Raises:
        ValueError: more than :data:`MAX_CAPSULES` capsules (the scene cannot hold them either).
    """
    positions = np.asarray(positions, np.float64).reshape(-1, 2)
    if len(positions) > MAX_CAPSULES:
        raise ValueError(f"a layout holds at most {MAX_CAPSULES} capsules, got {len(positions)}")
    layout = np.zeros((MAX_CAPSULES, len(LAYOUT_COLUMNS)), np.float32)
    mask = np.zeros(MAX_CAPSULES, np.float32)
    layout[: len(positions), :2] = positions
    layout[: len(positions), 2] = radius
    mask[: len(positions)] = 1.0
    return layout, mask


def true_state(physics: FlowNavPhysics) -> np.ndarray:
    """The drone's true state (:data:`TRUE_STATE_FIELDS`): world position, world velocity, roll, pitch, yaw
    (rad) and body angular rates (rad/s), clipped to the space's bounds."""
    roll, pitch = physics.roll_pitch()
    # A free joint's angular velocity (qvel[3:6]) is in the body frame.
    rates = np.asarray(physics.data.qvel[3:6], np.float64)
    values = np.concatenate(
        [physics.position(), physics.velocity_world(), [roll, pitch, physics.yaw()], rates]
    ).astype(np.float32)
    return np.clip(values, -_STATE_HIGH, _STATE_HIGH)


def course_info(settings: EnvSettings, goal_x: float, drone_radius: float) -> np.ndarray:
    """The course's geometry and the flight's limits (:data:`COURSE_INFO_FIELDS`; m, m/s, rad/s), with the
    drone's hull radius (m) and the agent's steps per second (Hz)."""
    values = (
        goal_x,
        settings.lateral_bound,
        settings.max_height,
        settings.forward_speed,
        settings.max_lateral_speed,
        settings.max_vertical_speed,
        settings.max_yaw_rate,
        drone_radius,
        settings.frame_rate,
    )
    return np.asarray(values, np.float32)


def camera_info(physics: FlowNavPhysics, settings: EnvSettings) -> np.ndarray:
    """The camera's true pose and horizontal intrinsics (:data:`CAMERA_FIELDS`) for the frame just taken: the
    mount's jitter included, as the image was rendered."""
    rotation, position = physics.camera_pose()
    intrinsics = settings.intrinsics()
    values = np.concatenate(
        [position, rotation.reshape(-1), [intrinsics.fx, intrinsics.cx, intrinsics.width]]
    )
    return np.clip(values, _CAMERA_LOW, _CAMERA_HIGH).astype(np.float32)


def privileged_observation(
    physics: FlowNavPhysics, settings: EnvSettings, goal_x: float
) -> dict[str, np.ndarray]:
    """The privileged keys of one step: the episode's capsules, the drone's true state, the course, the
    camera's pose and view, and the histogram's depth bin edges."""
    layout, mask = capsule_layout(physics.obstacle_positions, settings.obstacle_radius)
    edges = np.clip(np.asarray(settings.depth_bin_edges, np.float64), 0.0, POSITION_LIMIT_M)
    return {
        "layout": layout,
        "layout_mask": mask,
        "true_state": true_state(physics),
        "course": course_info(settings, goal_x, physics.quad.collision_radius),
        "camera": camera_info(physics, settings),
        "depth_bin_edges": edges.astype(np.float32),
    }
