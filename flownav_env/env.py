"""FlowNav-v0: a quadcopter with a forward camera flies through capsule obstacles, seeing depth only through
optical flow."""

from __future__ import annotations

import inspect
import math
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import cv2
import gymnasium as gym
import numpy as np
from gymnasium import spaces

from estimator import (
    DEFAULT_BIN_EDGES,
    CameraIntrinsics,
    DepthPoints,
    FlowDepthEstimator,
    sector_fraction,
    sector_histogram,
)
from flownav_env.camera import relative_motion
from flownav_env.physics import FlowNavPhysics
from flownav_env.quadrotor import ControllerGains, QuadrotorParams
from flownav_env.rendering import CameraRenderer, draw_flow_overlay
from flownav_env.scene import LAYOUT_FUNCTIONS, LAYOUTS, LayoutParams, material_names
from flownav_env.sensor import corrupt_motion, jitter_rotation

OBS_SOURCES = ("flow", "oracle", "oracle_valid")
STATE_FIELDS = (
    "forward_velocity",
    "lateral_velocity",
    "vertical_velocity",
    "roll",
    "pitch",
    "height",
    "heading_error",
)
STATE_LOW = np.array([-5.0, -5.0, -5.0, -math.pi, -math.pi / 2, 0.0, -math.pi], np.float32)
STATE_HIGH = np.array([5.0, 5.0, 5.0, math.pi, math.pi / 2, 10.0, math.pi], np.float32)
VIEW_PANEL_SIZE = (320, 240)
# The estimator's own FAST threshold (20) was chosen on 640×480 frames. The env's 160×120 frames hold a
# sixteenth of the pixels, and at 20 only about a third of the tracked points get a depth: too sparse a
# histogram to steer by. See "Default resolution and FAST threshold" in FlowNavEnv's docstring for the measurement.
ENV_ESTIMATOR_DEFAULTS: dict[str, Any] = {"fast_threshold": 10}


def _require_range(
    name: str, value: Any, low: float, high: float, *, low_open: bool = False, high_open: bool = False
) -> float:
    """``value`` as a float inside the given interval, else a ValueError naming the kwarg, value and range."""
    interval = f"{'(' if low_open else '['}{low}, {high}{')' if high_open else ']'}"
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a number in {interval}, got {value!r}")
    number = float(value)
    too_low = number <= low if low_open else number < low
    too_high = number >= high if high_open else number > high
    if not math.isfinite(number) or too_low or too_high:
        raise ValueError(f"{name} must be in {interval}, got {value!r}")
    return number


def _require_int(name: str, value: Any, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not low <= value <= high:
        raise ValueError(f"{name} must be an integer in [{low}, {high}], got {value!r}")
    return int(value)


def _require_choice(name: str, value: Any, choices: Sequence[str]) -> str:
    if value not in choices:
        raise ValueError(f"{name} must be one of {', '.join(map(repr, choices))}, got {value!r}")
    return value


class FlowNavEnv(gym.Env):
    r"""
    ## Description
    A ~1 kg quadrotor flies forward at a constant ``forward_speed`` through a course of vertical capsule
    obstacles (2 m tall, 0.5 m radius by default, as in the thesis) toward a goal line. Its only view of the
    obstacles is a forward camera: each step, the optical-flow depth estimator (:mod:`estimator`) tracks FAST
    keypoints from the last frame into the new one with pyramidal Lucas-Kanade flow, removes the rotation the
    drone knows it made, and turns the remaining flow into depth from the known translation. The depths are
    binned per image sector into a fixed-size histogram: that is what the agent sees. The agent steers by
    commanding sideways and vertical velocity and a yaw rate; an inner cascaded controller (velocity →
    attitude → rotor thrusts) flies the body, which really tilts to accelerate, so the rotation the estimator
    compensates comes from the flight.

    The sensor model carries the thesis's test variables: camera attitude jitter (known to the system),
    distance per frame (``forward_speed`` / ``frame_rate``), scene brightness, and relative errors on the
    rotation and translation the estimator is told. ``obs_source="oracle"`` replaces the estimated depths by
    the true depths at the same tracked points (ray-cast in the scene), separating estimator error from
    policy error; ``"oracle_valid"`` keeps only the points the estimator gave a valid depth but uses their
    true depth, separating *which* points the estimator delivers from *how well* it measures them.

    ## Action Space
    ``Box(-1, 1, (3,), float32)``; values outside [-1, 1] are clipped. Positive values steer toward the right
    and top of the camera image.

    | Num | Action                  | Min | Max | Scaled to                        | Unit  |
    |-----|-------------------------|-----|-----|----------------------------------|-------|
    | 0   | lateral velocity (right)| -1  | 1   | ± ``max_lateral_speed``          | m/s   |
    | 1   | vertical velocity (up)  | -1  | 1   | ± ``max_vertical_speed``         | m/s   |
    | 2   | yaw rate (to the right) | -1  | 1   | ± ``max_yaw_rate_deg``           | deg/s |

    Forward speed is not an action: the drone holds ``forward_speed`` along its heading.

    ## Observation Space
    ``Dict`` of float32 boxes (two, or three with ``observe_unresolved=True``):

    | Key               | Shape                   | Range                | Meaning                                   |
    |-------------------|-------------------------|----------------------|-------------------------------------------|
    | ``depth_histogram``| (rows, cols, bins)     | [0, 1]               | per image sector (``histogram_sectors``, row 0 at the top, column 0 at the left), the fraction of its valid depth points in each depth bin (``depth_bin_edges``, m; beyond the last edge counts in the last bin); an empty sector is all zeros |
    | ``state``         | (7,)                    | see below            | what a real drone knows of itself         |
    | ``unresolved``    | (rows, cols)            | [0, 1]               | only with ``observe_unresolved=True``: per sector, the share of the tracked points that got no depth to count (too little parallax: far away, or near the focus of expansion); 0 where nothing was tracked |

    ``state`` (clipped to the bounds of the space):

    | Num | Observation          | Min   | Max  | Unit |
    |-----|----------------------|-------|------|------|
    | 0   | forward velocity     | -5    | 5    | m/s  |
    | 1   | lateral velocity (left positive, body yaw frame) | -5 | 5 | m/s |
    | 2   | vertical velocity    | -5    | 5    | m/s  |
    | 3   | roll                 | -π    | π    | rad  |
    | 4   | pitch (nose down positive) | -π/2 | π/2 | rad |
    | 5   | height above ground  | 0     | 10   | m    |
    | 6   | heading error to the goal direction (+x; left positive) | -π | π | rad |

    ## Rewards
    Per step: ``reward = progress_weight · Δx + success_bonus · [goal reached] − collision_penalty ·
    [collision or out of bounds] − control_cost_weight · ‖action‖²``, where Δx is the metres gained toward the
    goal line this step. Each term is in ``info`` as ``reward_progress``, ``reward_success``,
    ``reward_collision`` and ``reward_control``.

    ## Starting State
    The drone starts at x = 0, y = 0, at ``flight_height``, heading +x and already moving at
    ``forward_speed``, in hover trim. The obstacle layout is drawn from the generator seeded by
    ``reset(seed=...)``; the start zone is kept clear.

    ## Episode End
    ### Termination
    1. Collision: any contact of the drone with an obstacle or the ground (``info["collision"]``).
    2. Goal: the drone crosses the goal line at the far end of the course (``info["success"]``).
    3. Out of bounds: more than ``lateral_bound`` metres sideways of the course axis or above
       ``max_height`` (``info["out_of_bounds"]``), so that flying around or over the field is no solution.
    ### Truncation
    The time limit: ``max_episode_steps`` given at registration (400 steps for ``FlowNav-v0``, 40 s).

    ## Arguments
    | Argument | Default | Meaning |
    |---|---|---|
    | ``layout`` | ``"field"`` | ``"field"``, ``"corridor"``, ``"single"`` (thesis Fig. 14) or ``"three"`` (Fig. 41) |
    | ``obstacle_density`` | 0.12 | field capsules per m² of the obstacle band, in [0, 1] |
    | ``obstacle_radius`` | 0.5 | capsule radius (m), in (0, 2] |
    | ``obstacle_height`` | 2.0 | capsule height (m), in (2·radius, 10] |
    | ``field_length`` | 20.0 | start to goal line for field and corridor (m), in [5, 200] |
    | ``field_width`` | 8.0 | width of the band holding field capsules (m), in [1, 100] |
    | ``corridor_width`` | 2.5 | free width of a corridor (m), in (0, 20] |
    | ``corridor_bend`` | 1.5 | largest sideways excursion of a corridor (m), in [0, 10] |
    | ``forward_speed`` | 1.0 | forward speed (m/s), in [0, 5]; 0 hovers |
    | ``frame_rate`` | 10.0 | camera frames = agent steps per second (Hz), in [1, 50] |
    | ``flight_height`` | 1.0 | starting height (m), in [0.3, 5] |
    | ``max_height`` | 1.8 | out of bounds above this height (m), > ``flight_height`` |
    | ``lateral_bound`` | 6.0 | out of bounds beyond this sideways distance from the course axis (m), in (0, 100] |
    | ``camera_width``, ``camera_height`` | 160, 120 | camera resolution (px), each in [16, 1280] |
    | ``camera_fov_deg`` | 60 | vertical field of view (deg), in [10, 150] |
    | ``attitude_jitter_deg`` | 0 | camera attitude disturbance per frame, uniform ± per axis (deg), in [0, 10] |
    | ``brightness`` | 1.0 | scene light level (1 = daylight), in [0, 4] |
    | ``rotation_error`` | 0 | relative error of the rotation told to the estimator, in [0, 1] |
    | ``translation_error`` | 0 | relative error of the translation told to the estimator, in [0, 1] |
    | ``obs_source`` | ``"flow"`` | ``"flow"`` (estimator), ``"oracle"`` (true depth at the tracked points) or ``"oracle_valid"`` (true depth at the points with a valid estimate) |
    | ``histogram_sectors`` | (3, 5) | sector rows, columns, each in [1, 32] |
    | ``observe_unresolved`` | False | add the ``unresolved`` key: where the estimator tracks points it cannot range (a histogram counts only ranged points, so it cannot tell a lone near point in open space from a wall) |
    | ``depth_bin_edges`` | ``estimator.DEFAULT_BIN_EDGES`` | increasing depth bin edges (m) |
    | ``max_lateral_speed`` | 1.0 | lateral speed at action 1 (m/s), in (0, 5] |
    | ``max_vertical_speed`` | 0.5 | vertical speed at action 1 (m/s), in (0, 5] |
    | ``max_yaw_rate_deg`` | 45 | yaw rate at action 1 (deg/s), in (0, 360] |
    | ``progress_weight`` | 1.0 | reward per metre of progress, ≥ 0 |
    | ``success_bonus`` | 10.0 | reward on reaching the goal, ≥ 0 |
    | ``collision_penalty`` | 10.0 | penalty on collision or leaving the bounds, ≥ 0 |
    | ``control_cost_weight`` | 0.05 | weight of ‖action‖², ≥ 0 |
    | ``estimator_kwargs`` | None | keyword arguments of ``estimator.FlowDepthEstimator`` (method, thresholds, ...), over ``ENV_ESTIMATOR_DEFAULTS`` (``fast_threshold=10``) |
    | ``texture_seed`` | 0 | seed of the procedural textures (the world's look) |
    | ``physics_timestep`` | 0.004 | MuJoCo timestep (s), in [0.0005, 0.005] (physics ≥ 200 Hz) |
    | ``render_mode`` | None | ``"rgb_array"``: camera view with the flow overlay beside a chase view |

    Rendering is offscreen through MuJoCo's ``MUJOCO_GL`` backend; importing :mod:`flownav_env` sets it to
    ``egl`` unless it is already set (``osmesa`` also works where installed).

    ## Default resolution and FAST threshold
    160×120 and a FAST threshold of 10 (``ENV_ESTIMATOR_DEFAULTS``; the estimator's own default, 20, was
    chosen on 640×480 frames), chosen by measurement (``flownav bench env``, ``results/env_performance.md``: one
    process, the field layout and a scripted flight, medians per frame; a 2-core CPU with software OpenGL, other
    jobs running, so steps/s are good to about ±10 %):

    | resolution | FAST | steps/s | points tracked | points valid | median depth error |
    |------------|------|---------|----------------|--------------|--------------------|
    | 64×48      | 10   | 128     | 47             | 8            | 10.2 %             |
    | 96×72      | 10   | 124     | 97             | 37           | 6.5 %              |
    | 128×96     | 10   | 112     | 161            | 80           | 4.9 %              |
    | 160×120    | 10   | 99–105  | 236            | 134          | 4.0 %              |
    | 240×180    | 10   | 79      | 500            | 321          | 2.8 %              |
    | 320×240    | 10   | 62      | 896            | 609          | 2.0 %              |
    | 160×120    | 20   | 109     | 79             | 34           | 4.1 %              |

    Criteria: a median depth error ≤ 5 % and at least two valid points per histogram sector. The resolution
    was chosen at threshold 20, where 160×120 was the smallest size meeting both (34 valid points for 3×5
    sectors). At threshold 10, 128×96 also meets them, but only just (4.9 %), and 160×120 stays. The threshold
    costs little: the estimator takes about 0.9 ms more per step at 10 than at 20 (2.2 against 1.4 ms, about
    6 % of the steps/s), and it gives four times the valid depths at the same median error. It is the lever
    that matters for flying. The same PPO policy, flown on 100 held-out layouts, collided in 0.50 of them at
    threshold 20 and in 0.28 at threshold 10 (``results/benchmark.md``). Rendering is the largest stage at
    every size (software OpenGL).

    ## Version History
    * v0: initial version (FAST threshold 10 since the benchmark's second sweep; 20 before).
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(
        self,
        layout: str = "field",
        obstacle_density: float = 0.12,
        obstacle_radius: float = 0.5,
        obstacle_height: float = 2.0,
        field_length: float = 20.0,
        field_width: float = 8.0,
        corridor_width: float = 2.5,
        corridor_bend: float = 1.5,
        forward_speed: float = 1.0,
        frame_rate: float = 10.0,
        flight_height: float = 1.0,
        max_height: float = 1.8,
        lateral_bound: float = 6.0,
        camera_width: int = 160,
        camera_height: int = 120,
        camera_fov_deg: float = 60.0,
        attitude_jitter_deg: float = 0.0,
        brightness: float = 1.0,
        rotation_error: float = 0.0,
        translation_error: float = 0.0,
        obs_source: str = "flow",
        histogram_sectors: Sequence[int] = (3, 5),
        observe_unresolved: bool = False,
        depth_bin_edges: Sequence[float] = tuple(DEFAULT_BIN_EDGES),
        max_lateral_speed: float = 1.0,
        max_vertical_speed: float = 0.5,
        max_yaw_rate_deg: float = 45.0,
        progress_weight: float = 1.0,
        success_bonus: float = 10.0,
        collision_penalty: float = 10.0,
        control_cost_weight: float = 0.05,
        estimator_kwargs: Mapping[str, Any] | None = None,
        texture_seed: int = 0,
        physics_timestep: float = 0.004,
        render_mode: str | None = None,
    ) -> None:
        self.layout = _require_choice("layout", layout, LAYOUTS)
        self.obs_source = _require_choice("obs_source", obs_source, OBS_SOURCES)
        if not isinstance(observe_unresolved, (bool, np.bool_)):
            raise ValueError(f"observe_unresolved must be True or False, got {observe_unresolved!r}")
        self.observe_unresolved = bool(observe_unresolved)
        if render_mode is not None:
            _require_choice("render_mode", render_mode, self.metadata["render_modes"])
        self.render_mode = render_mode

        radius = _require_range("obstacle_radius", obstacle_radius, 0.0, 2.0, low_open=True)
        self.layout_params = LayoutParams(
            obstacle_radius=radius,
            obstacle_height=_require_range(
                "obstacle_height", obstacle_height, 2 * radius, 10.0, low_open=True
            ),
            obstacle_density=_require_range("obstacle_density", obstacle_density, 0.0, 1.0),
            field_length=_require_range("field_length", field_length, 5.0, 200.0),
            field_width=_require_range("field_width", field_width, 1.0, 100.0),
            corridor_width=_require_range("corridor_width", corridor_width, 0.0, 20.0, low_open=True),
            corridor_bend=_require_range("corridor_bend", corridor_bend, 0.0, 10.0),
        )
        self.forward_speed = _require_range("forward_speed", forward_speed, 0.0, 5.0)
        self.frame_rate = _require_range("frame_rate", frame_rate, 1.0, 50.0)
        self.flight_height = _require_range("flight_height", flight_height, 0.3, 5.0)
        self.max_height = _require_range("max_height", max_height, self.flight_height, 20.0, low_open=True)
        self.lateral_bound = _require_range("lateral_bound", lateral_bound, 0.0, 100.0, low_open=True)
        width = _require_int("camera_width", camera_width, 16, 1280)
        height = _require_int("camera_height", camera_height, 16, 1280)
        fov = _require_range("camera_fov_deg", camera_fov_deg, 10.0, 150.0)
        self.attitude_jitter_deg = _require_range("attitude_jitter_deg", attitude_jitter_deg, 0.0, 10.0)
        self.brightness = _require_range("brightness", brightness, 0.0, 4.0)
        self.rotation_error = _require_range("rotation_error", rotation_error, 0.0, 1.0)
        self.translation_error = _require_range("translation_error", translation_error, 0.0, 1.0)
        if (
            isinstance(histogram_sectors, (str, bytes))
            or not isinstance(histogram_sectors, Sequence)
            or len(histogram_sectors) != 2
        ):
            raise ValueError(f"histogram_sectors must be (rows, cols), got {histogram_sectors!r}")
        self.histogram_sectors = (
            _require_int("histogram_sectors[0]", histogram_sectors[0], 1, 32),
            _require_int("histogram_sectors[1]", histogram_sectors[1], 1, 32),
        )
        edges = np.asarray(depth_bin_edges, np.float64)
        if (
            edges.ndim != 1
            or len(edges) < 2
            or not np.all(np.isfinite(edges))
            or np.any(np.diff(edges) <= 0)
            or edges[0] < 0
        ):
            raise ValueError(
                f"depth_bin_edges must be >= 2 increasing finite depths >= 0 m, got {depth_bin_edges!r}"
            )
        self.depth_bin_edges = edges
        self.max_lateral_speed = _require_range(
            "max_lateral_speed", max_lateral_speed, 0.0, 5.0, low_open=True
        )
        self.max_vertical_speed = _require_range(
            "max_vertical_speed", max_vertical_speed, 0.0, 5.0, low_open=True
        )
        self.max_yaw_rate = math.radians(
            _require_range("max_yaw_rate_deg", max_yaw_rate_deg, 0.0, 360.0, low_open=True)
        )
        self.progress_weight = _require_range(
            "progress_weight", progress_weight, 0.0, math.inf, high_open=True
        )
        self.success_bonus = _require_range("success_bonus", success_bonus, 0.0, math.inf, high_open=True)
        self.collision_penalty = _require_range(
            "collision_penalty", collision_penalty, 0.0, math.inf, high_open=True
        )
        self.control_cost_weight = _require_range(
            "control_cost_weight", control_cost_weight, 0.0, math.inf, high_open=True
        )
        timestep = _require_range("physics_timestep", physics_timestep, 0.0005, 0.005)
        self.substeps = max(1, round(1.0 / (self.frame_rate * timestep)))
        if not isinstance(texture_seed, (int, np.integer)) or isinstance(texture_seed, bool):
            raise ValueError(f"texture_seed must be an integer, got {texture_seed!r}")

        self.intrinsics = CameraIntrinsics.from_fov(width, height, fov)
        self.estimator = FlowDepthEstimator(
            self.intrinsics, **{**ENV_ESTIMATOR_DEFAULTS, **_estimator_overrides(estimator_kwargs)}
        )
        self.physics = FlowNavPhysics(
            self.layout_params,
            QuadrotorParams(),
            ControllerGains(),
            timestep=timestep,
            camera_fov_deg=fov,
            offscreen_size=(max(width, VIEW_PANEL_SIZE[0]), max(height, VIEW_PANEL_SIZE[1])),
            texture_seed=int(texture_seed),
        )
        self.physics.set_brightness(self.brightness)
        self._camera = CameraRenderer(self.physics.model, width, height)
        self._view: CameraRenderer | None = None
        self._materials = len(material_names())

        rows, cols = self.histogram_sectors
        boxes = {
            "depth_histogram": spaces.Box(0.0, 1.0, (rows, cols, len(edges) - 1), np.float32),
            "state": spaces.Box(STATE_LOW, STATE_HIGH, dtype=np.float32),
        }
        if self.observe_unresolved:
            boxes["unresolved"] = spaces.Box(0.0, 1.0, (rows, cols), np.float32)
        self.observation_space = spaces.Dict(boxes)
        self.action_space = spaces.Box(-1.0, 1.0, (3,), np.float32)

        self._goal_x = self.layout_params.field_length
        self._camera_pose: tuple[np.ndarray, np.ndarray] = (np.eye(3), np.zeros(3))
        self._frame: np.ndarray | None = None
        self._depth_points: DepthPoints | None = None
        self._min_clearance = math.inf

    # --- Gymnasium API ----------------------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        rng = self.np_random
        positions, self._goal_x = LAYOUT_FUNCTIONS[self.layout](rng, self.layout_params)
        self.physics.place_obstacles(positions, rng.integers(self._materials, size=len(positions)))
        start = np.array([0.0, 0.0, self.flight_height])
        self.physics.reset_drone(start, 0.0, np.array([self.forward_speed, 0.0, 0.0]))
        self.physics.set_camera_mount(jitter_rotation(self.attitude_jitter_deg, rng))
        self._camera_pose = self.physics.camera_pose()
        self._min_clearance = self.physics.obstacle_clearance()

        self.estimator.reset()
        self._frame = self._camera.render(self.physics.data, self.physics.camera_id)
        self._depth_points = self.estimator.update(self._gray(self._frame), np.eye(3), np.zeros(3))
        histogram = np.zeros(self.observation_space["depth_histogram"].shape, np.float32)
        no_points = np.zeros(len(self._depth_points.points), bool)
        info = {
            "collision": False,
            "success": False,
            "out_of_bounds": False,
            "progress": 0.0,
            "clearance": self._min_clearance,
            "min_clearance": self._min_clearance,
            **self._estimator_info(self._depth_points, np.zeros(0)),
        }
        return self._observation(histogram, self._depth_points, no_points), info

    def step(self, action):
        action = np.clip(np.asarray(action, np.float64).reshape(3), -1.0, 1.0)
        if not np.all(np.isfinite(action)):
            raise ValueError(f"action must be finite, got {action!r}")
        x_before = self.physics.position()[0]
        velocity_target = self._velocity_target(action)
        rng = self.np_random
        collision = self.physics.advance(
            velocity_target,
            -action[2] * self.max_yaw_rate,
            self.substeps,
            camera_disturbance=jitter_rotation(self.attitude_jitter_deg, rng),
        )
        previous_pose, self._camera_pose = self._camera_pose, self.physics.camera_pose()
        true_rotation, true_translation = relative_motion(*previous_pose, *self._camera_pose)
        told_rotation, told_translation = corrupt_motion(
            true_rotation, true_translation, self.rotation_error, self.translation_error, rng
        )
        self._frame = self._camera.render(self.physics.data, self.physics.camera_id)
        points = self.estimator.update(self._gray(self._frame), told_rotation, told_translation)
        self._depth_points = points
        true_depth = self._true_depth(points.points, previous_pose)
        if self.obs_source == "oracle":
            # The same points the estimator tracked, with their true depth (parallax or not).
            depth, valid = true_depth, points.tracked & np.isfinite(true_depth)
        elif self.obs_source == "oracle_valid":
            depth, valid = true_depth, points.valid & np.isfinite(true_depth)
        else:
            depth, valid = points.depth, points.valid
        histogram = sector_histogram(
            points.points,
            depth,
            valid,
            self.intrinsics.image_size,
            sectors=self.histogram_sectors,
            bin_edges=self.depth_bin_edges,
        )

        position = self.physics.position()
        clearance = self.physics.obstacle_clearance()
        self._min_clearance = min(self._min_clearance, clearance)
        success = bool(position[0] >= self._goal_x and not collision)
        out_of_bounds = bool(abs(position[1]) > self.lateral_bound or position[2] > self.max_height)
        terms = {
            "reward_progress": self.progress_weight * float(position[0] - x_before),
            "reward_success": self.success_bonus * float(success),
            "reward_collision": -self.collision_penalty * float(collision or out_of_bounds),
            "reward_control": -self.control_cost_weight * float(action @ action),
        }
        info = {
            "collision": collision,
            "success": success,
            "out_of_bounds": out_of_bounds,
            "progress": float(position[0]),
            "clearance": clearance,
            "min_clearance": self._min_clearance,
            "position": position,
            "true_rotation": true_rotation,
            "true_translation": true_translation,
            **self._estimator_info(points, true_depth),
            **terms,
        }
        observation = self._observation(histogram, points, valid)
        terminated = collision or success or out_of_bounds
        return observation, float(sum(terms.values())), terminated, False, info

    def render(self) -> np.ndarray | None:
        """With ``render_mode="rgb_array"``: the camera frame with tracked points, flow vectors and depth-coloured
        circles (thesis Figs. 25–27), beside a chase view; (240, 640, 3) uint8."""
        if self.render_mode != "rgb_array" or self._frame is None:
            return None
        panel_width, panel_height = VIEW_PANEL_SIZE
        if self._view is None:
            self._view = CameraRenderer(self.physics.model, panel_width, panel_height)
        points = self._depth_points
        scale = max(1, min(panel_width // self._frame.shape[1], panel_height // self._frame.shape[0]))
        overlay = draw_flow_overlay(
            self._frame,
            points.points,
            points.next_points,
            points.depth,
            points.valid,
            scale=scale,
            max_depth=float(self.depth_bin_edges[-1]),
        )
        camera_panel = np.zeros((panel_height, panel_width, 3), np.uint8)
        camera_panel[: overlay.shape[0], : overlay.shape[1]] = overlay[:panel_height, :panel_width]
        chase = self._view.render(self.physics.data, "chase")
        return np.concatenate([camera_panel, chase], axis=1)

    def close(self) -> None:
        self._camera.close()
        if self._view is not None:
            self._view.close()
            self._view = None

    # --- helpers ----------------------------------------------------------------------------------------------
    def _observation(
        self, histogram: np.ndarray, points: DepthPoints, counted: np.ndarray
    ) -> dict[str, np.ndarray]:
        observation = {"depth_histogram": histogram, "state": self._state()}
        if self.observe_unresolved:
            observation["unresolved"] = sector_fraction(
                points.points,
                points.tracked & ~counted,
                points.tracked,
                self.intrinsics.image_size,
                sectors=self.histogram_sectors,
            )
        return observation

    @staticmethod
    def _gray(frame: np.ndarray) -> np.ndarray:
        return cv2.cvtColor(frame, cv2.COLOR_RGB2GRAY)

    def _velocity_target(self, action: np.ndarray) -> np.ndarray:
        """World-frame velocity command: forward speed along the heading, sideways and vertical from the action."""
        yaw = self.physics.yaw()
        forward = np.array([math.cos(yaw), math.sin(yaw), 0.0])
        left = np.array([-math.sin(yaw), math.cos(yaw), 0.0])
        return (
            self.forward_speed * forward
            - action[0] * self.max_lateral_speed * left
            + np.array([0.0, 0.0, action[1] * self.max_vertical_speed])
        )

    def _true_depth(self, pixels: np.ndarray, camera_pose: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
        """True z-depth at ``pixels`` of the frame taken at ``camera_pose`` (NaN where the ray hits nothing)."""
        if len(pixels) == 0:
            return np.zeros(0)
        rays = np.column_stack([self.intrinsics.normalize(pixels), np.ones(len(pixels))])
        return self.physics.ray_depths(rays, *camera_pose)

    @staticmethod
    def _estimator_info(points: DepthPoints, true_depth: np.ndarray) -> dict[str, Any]:
        """Estimator statistics; ``depth_error_median`` only when some valid point has a ground truth."""
        valid = np.asarray(points.valid, bool)
        comparable = (
            valid & np.isfinite(true_depth) if len(true_depth) == len(valid) else np.zeros_like(valid)
        )
        info: dict[str, Any] = {"points_tracked": len(valid), "points_valid": int(valid.sum())}
        if comparable.any():
            relative = np.abs(points.depth[comparable] - true_depth[comparable]) / true_depth[comparable]
            info["depth_error_median"] = float(np.median(relative))
        return info

    def _state(self) -> np.ndarray:
        physics = self.physics
        yaw = physics.yaw()
        cos_yaw, sin_yaw = math.cos(yaw), math.sin(yaw)
        vx, vy, vz = physics.velocity_world()
        roll, pitch = physics.roll_pitch()
        state = np.array(
            [
                cos_yaw * vx + sin_yaw * vy,
                -sin_yaw * vx + cos_yaw * vy,
                vz,
                roll,
                pitch,
                physics.position()[2],
                math.atan2(math.sin(yaw), math.cos(yaw)),
            ],
            np.float32,
        )
        return np.clip(state, STATE_LOW, STATE_HIGH)


def _estimator_overrides(estimator_kwargs: Mapping[str, Any] | None) -> dict[str, Any]:
    """``estimator_kwargs`` as a dict, its keys checked against FlowDepthEstimator's parameters."""
    if estimator_kwargs is None:
        return {}
    if not isinstance(estimator_kwargs, Mapping):
        raise ValueError(
            f"estimator_kwargs must be a mapping of FlowDepthEstimator arguments, got {estimator_kwargs!r}"
        )
    allowed = [name for name in inspect.signature(FlowDepthEstimator).parameters if name != "intrinsics"]
    unknown = sorted(set(estimator_kwargs) - set(allowed))
    if unknown:
        raise ValueError(f"estimator_kwargs has unknown keys {unknown}; allowed: {', '.join(allowed)}")
    return dict(estimator_kwargs)
