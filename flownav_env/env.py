"""FlowNav-v0: a quadcopter with a forward camera flies through capsule obstacles, seeing depth only through
optical flow."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import fields
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np

from estimator import DEFAULT_BIN_EDGES, DepthPoints, FlowDepthEstimator
from flownav_env.actions import action_space, checked_action
from flownav_env.observation import (
    assemble_observation,
    depth_histogram,
    drone_state,
    estimator_info,
    observation_space,
    observed_depths,
    smoothed_near,
)
from flownav_env.physics import FlowNavPhysics
from flownav_env.quadrotor import ControllerGains, QuadrotorParams, velocity_command
from flownav_env.rendering import VIEW_PANEL_SIZE, CameraRenderer, camera_panel
from flownav_env.rewards import reward_terms
from flownav_env.scene import LAYOUT_FUNCTIONS, LayoutParams, material_names
from flownav_env.sensor import Pose, SensorPipeline
from flownav_env.settings import Choice, EnvSettings, settings_property, with_sensor_settings


@with_sensor_settings
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
    rotation and translation the estimator is told; beside them, real sensors' errors on the told motion and on
    the estimated depths (bias, drift, noise floor, outliers, dropout: :mod:`flownav_env.settings`).
    ``obs_source="oracle"`` replaces the estimated depths by the true depths at the same tracked points
    (ray-cast), separating estimator error from policy error; ``"oracle_valid"`` keeps only the points with a
    valid estimate but uses their true depth: *which* points the estimator delivers vs *how well* it measures.

    ## Action Space
    ``Box(-1, 1, (3,), float32)``; values outside [-1, 1] are clipped; any other shape (a (1, 3) batch too)
    or a NaN or infinite value raises ValueError. Positive values steer toward the right and top of the camera
    image. Forward speed is not an action: the drone holds ``forward_speed``.

    | Num | Action                  | Min | Max | Scaled to                        | Unit  |
    |-----|-------------------------|-----|-----|----------------------------------|-------|
    | 0   | lateral velocity (right)| -1  | 1   | ± ``max_lateral_speed``          | m/s   |
    | 1   | vertical velocity (up)  | -1  | 1   | ± ``max_vertical_speed``         | m/s   |
    | 2   | yaw rate (to the right) | -1  | 1   | ± ``max_yaw_rate_deg``           | deg/s |

    ## Observation Space
    ``Dict`` of float32 boxes: two, plus one per ``observe_unresolved``, ``observe_counts``, ``observe_nearness``,
    ``observe_approach``:

    | Key               | Shape                   | Range                | Meaning                                   |
    |-------------------|-------------------------|----------------------|-------------------------------------------|
    | ``depth_histogram``| (rows, cols, bins)     | [0, 1]               | per image sector (``histogram_sectors``, row 0 at the top, column 0 at the left), the fraction of its valid depth points in each depth bin (``depth_bin_edges``, m; beyond the last edge counts in the last bin); an empty sector is all zeros |
    | ``state``         | (7,)                    | see below            | what a real drone knows of itself         |
    | ``unresolved``    | (rows, cols)            | [0, 1]               | only with ``observe_unresolved=True``: per sector, the share of the tracked points that got no depth to count (too little parallax: far away, or near the focus of expansion); 0 where nothing was tracked |
    | ``point_counts``  | (rows, cols)            | [0, 1]               | only with ``observe_counts=True``: per sector, the confidence 1 − exp(−n/10) of the n points its histogram counts |
    | ``nearness``      | (rows, cols)            | [0, 1]               | only with ``observe_nearness=True``: per sector, min(1, 0.5 m / d) of a robust near depth d (``estimator.sector_near_depth``: a low quantile of its depths, never one lone point); 0 where no depth counts |
    | ``approach``      | (rows, cols)            | [0, 1]               | only with ``observe_approach=True``: per sector, min(1, 0.5 s · v / d) for the same d and the forward velocity v (0 when flying backwards): the inverse time to contact, as a bee's optic flow gives it; at 1 m/s it equals ``nearness`` |

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
    [collision or out of bounds] − control_cost_weight · ‖action‖² − clearance_weight · max(0, 1 − c /
    safe_clearance)``, where Δx is the metres gained toward the goal line this step and c the distance from the
    drone's centre to the nearest capsule surface. Each term is in ``info`` as ``reward_progress``,
    ``reward_success``, ``reward_collision``, ``reward_control`` and ``reward_clearance``.

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
    | ``max_height`` | 1.8 | out of bounds above this height (m), in (``flight_height``, 20] |
    | ``lateral_bound`` | 6.0 | out of bounds beyond this sideways distance from the course axis (m), in (0, 100] |
    | ``camera_width``, ``camera_height`` | 160, 120 | camera resolution (px), each in [16, 1280] |
    | ``camera_fov_deg`` | 60 | vertical field of view (deg), in [10, 150] |
    {sensor_rows}
    | ``obs_source`` | ``"flow"`` | ``"flow"`` (estimator), ``"oracle"`` (true depth at the tracked points) or ``"oracle_valid"`` (true depth at the points with a valid estimate) |
    | ``histogram_sectors`` | (3, 5) | sector rows, columns, each in [1, 32] |
    | ``observe_unresolved``, ``observe_counts``, ``observe_nearness``, ``observe_approach`` | False | add the ``unresolved`` key (where the estimator tracks points it cannot range: a histogram counts only ranged points, so it cannot tell a lone near point in open space from a wall), the ``point_counts`` key (how much each sector's histogram rests on), the ``nearness`` key (how near each sector's nearest surface is; a histogram spreads it over bins) or the ``approach`` key (how soon the drone reaches it at its forward speed) |
    | ``near_smoothing`` | 1.0 | weight of the newest frame in ``nearness`` and ``approach``'s exponential average over the episode's frames, in (0, 1]; 1 = this frame only |
    | ``depth_error_info`` | True | ray-cast the true depth of the tracked points each step for ``info["depth_error_median"]`` and ``info["depth_outlier_share"]`` (off by > 50 %); False skips it (about 0.3 ms per step) where only flow observations are used, as in training |
    | ``depth_bin_edges`` | ``estimator.DEFAULT_BIN_EDGES`` | increasing depth bin edges (m) |
    | ``max_lateral_speed``, ``max_vertical_speed`` | 1.0, 0.5 | lateral and vertical speed at action 1 (m/s), each in (0, 5] |
    | ``max_yaw_rate_deg`` | 45 | yaw rate at action 1 (deg/s), in (0, 360] |
    | ``progress_weight`` | 1.0 | reward per metre of progress, ≥ 0 |
    | ``success_bonus``, ``collision_penalty`` | 10.0, 10.0 | reward on reaching the goal; penalty on collision or leaving the bounds; each ≥ 0 |
    | ``control_cost_weight`` | 0.05 | weight of ‖action‖², ≥ 0 |
    | ``clearance_weight``, ``safe_clearance`` | 0.0, 0.5 | clearance shaping: the most a step closer than ``safe_clearance`` (m, in (0, 5]) to a capsule can cost, ≥ 0; 0 turns it off |
    | ``estimator_kwargs`` | None | keyword arguments of ``estimator.FlowDepthEstimator`` (method, thresholds, ...), over ``ENV_ESTIMATOR_DEFAULTS`` (``fast_threshold=10``) |
    | ``texture_seed`` | 0 | seed of the procedural textures (the world's look) |
    | ``physics_timestep`` | 0.004 | MuJoCo timestep (s), in [0.0005, 0.005] (physics ≥ 200 Hz) |
    | ``render_mode`` | None | ``"rgb_array"``: camera view with the flow overlay beside a chase view |

    Between episodes, :meth:`set_sensor` and :meth:`set_course` change what training randomises. The default
    resolution (160×120) and FAST threshold (10) were measured: ``results/env_performance.md``.

    ## Version History
    * v0: initial version (FAST threshold 10 since the benchmark's second sweep; 20 before). Since 2026-11-23 the
      camera's near plane is at 5 cm (it was 1.22 m, and nearer capsules rendered hollow): results differ.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "render_fps": 10}

    layout = settings_property("layout")
    obs_source = settings_property("obs_source")
    forward_speed = settings_property("forward_speed")
    frame_rate = settings_property("frame_rate")
    histogram_sectors = settings_property("histogram_sectors")
    substeps = settings_property("substeps")

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
        rotation_bias: float = 0.0,
        translation_bias: float = 0.0,
        rotation_drift: float = 0.0,
        translation_drift: float = 0.0,
        rotation_noise_deg: float = 0.0,
        translation_noise_m: float = 0.0,
        depth_noise: float = 0.0,
        depth_outliers: float = 0.0,
        depth_dropout: float = 0.0,
        obs_source: str = "flow",
        histogram_sectors: Sequence[int] = (3, 5),
        observe_unresolved: bool = False,
        observe_counts: bool = False,
        observe_nearness: bool = False,
        observe_approach: bool = False,
        near_smoothing: float = 1.0,
        depth_error_info: bool = True,
        depth_bin_edges: Sequence[float] = tuple(DEFAULT_BIN_EDGES),
        max_lateral_speed: float = 1.0,
        max_vertical_speed: float = 0.5,
        max_yaw_rate_deg: float = 45.0,
        progress_weight: float = 1.0,
        success_bonus: float = 10.0,
        collision_penalty: float = 10.0,
        control_cost_weight: float = 0.05,
        clearance_weight: float = 0.0,
        safe_clearance: float = 0.5,
        estimator_kwargs: Mapping[str, Any] | None = None,
        texture_seed: int = 0,
        physics_timestep: float = 0.004,
        render_mode: str | None = None,
    ) -> None:
        # Every argument but render_mode is a setting (a test keeps the two lists equal).
        arguments = dict(locals())
        if render_mode is not None:
            Choice(tuple(self.metadata["render_modes"])).check("render_mode", render_mode)
        self.render_mode = render_mode
        self.settings = EnvSettings(**{item.name: arguments[item.name] for item in fields(EnvSettings)})
        settings = self.settings
        self.intrinsics = settings.intrinsics()
        self.estimator = FlowDepthEstimator(self.intrinsics, **settings.estimator_arguments())
        self.physics = FlowNavPhysics(
            self.layout_params,
            QuadrotorParams(),
            ControllerGains(),
            timestep=settings.physics_timestep,
            camera_fov_deg=settings.camera_fov_deg,
            offscreen_size=tuple(np.maximum(self.intrinsics.image_size, VIEW_PANEL_SIZE).tolist()),
            texture_seed=settings.texture_seed,
        )
        self.physics.set_brightness(settings.brightness)
        self._camera = CameraRenderer(
            self.physics.model, settings.camera_width, settings.camera_height, onboard=True
        )
        self._view: CameraRenderer | None = None
        self._closed = False
        self._materials = len(material_names())
        self._sensor = SensorPipeline(settings.frame_rate)

        self.observation_space = observation_space(settings)
        self.action_space = action_space()

        self._goal_x = self.layout_params.field_length
        self._frame: np.ndarray | None = None
        self._depth_points: DepthPoints | None = None
        self._observed: dict[str, np.ndarray] | None = None  # the last observation, for near_smoothing
        self._min_clearance = math.inf

    @property
    def depth_bin_edges(self) -> np.ndarray:  # as a float64 array (m)
        return np.asarray(self.settings.depth_bin_edges, np.float64)

    def set_sensor(self, **values: float) -> None:
        """Change sensor variables (:data:`~flownav_env.settings.SENSOR_FIELDS`) between episodes, as training
        randomisation does; the next frame uses them (a new bias is applied with the walk so far).

        Raises:
            ValueError: A name is not a sensor variable, or a value is outside its range (the message names
                the variable, the value and the range).
        """
        self.settings = self.settings.with_sensor(**values)
        self.physics.set_brightness(self.settings.brightness)

    def set_course(self, **values: float) -> None:
        """Change ``forward_speed`` or ``obstacle_density`` from the next reset on; checked as set_sensor."""
        self.settings = self.settings.with_course(**values)

    @property
    def layout_params(self) -> LayoutParams:  # of the current settings
        return self.settings.layout_params()

    # --- Gymnasium API ----------------------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        self._require_open("reset")
        super().reset(seed=seed)
        rng = self.np_random
        positions, self._goal_x = LAYOUT_FUNCTIONS[self.layout](rng, self.layout_params)
        self.physics.place_obstacles(positions, rng.integers(self._materials, size=len(positions)))
        start = np.array([0.0, 0.0, self.settings.flight_height])
        self.physics.reset_drone(start, 0.0, np.array([self.forward_speed, 0.0, 0.0]))

        def mount_camera(jitter: np.ndarray) -> Pose:
            self.physics.set_camera_mount(jitter)
            return self.physics.camera_pose()

        frame = self._sensor.capture(self.settings.sensor, rng, mount_camera, self._render_camera, first=True)
        self._frame = frame.image
        self._min_clearance = self.physics.obstacle_clearance()
        self.estimator.reset()
        self._observed = None
        points = self._depth_points = self.estimator.update(frame.gray, *frame.told_motion)
        histogram = np.zeros(self.observation_space["depth_histogram"].shape, np.float32)
        info = {"collision": False, "success": False, "out_of_bounds": False, "progress": 0.0}
        info |= {"clearance": self._min_clearance, "min_clearance": self._min_clearance}
        info |= estimator_info(points, np.zeros(0))
        return self._observation(histogram, points, points.depth, np.zeros(len(points.points), bool)), info

    def step(self, action):
        self._require_open("step")
        action = checked_action(action)
        settings = self.settings
        x_before = self.physics.position()[0]
        speeds = (self.forward_speed, settings.max_lateral_speed, settings.max_vertical_speed)
        velocity_target = velocity_command(self.physics.yaw(), action, *speeds)
        collision = False

        def fly(jitter: np.ndarray) -> Pose:
            nonlocal collision
            collision = self.physics.advance(
                velocity_target,
                -action[2] * settings.max_yaw_rate,
                settings.substeps,
                camera_disturbance=jitter,
            )
            return self.physics.camera_pose()

        frame = self._sensor.capture(settings.sensor, self.np_random, fly, self._render_camera, first=False)
        self._frame = frame.image
        points = self.estimator.update(frame.gray, *frame.told_motion)
        points = self._depth_points = self._sensor.corrupt_points(settings, self.np_random, points)
        # True depth at the tracked points of the previous frame (NaN where a ray hits nothing).
        needs_truth = settings.depth_error_info or settings.obs_source != "flow"
        true_depth = np.zeros(0)
        if needs_truth:
            true_depth = self.physics.ray_depths(self.intrinsics.rays(points.points), *frame.previous_pose)
        depth, valid = observed_depths(settings.obs_source, points, true_depth)
        histogram = depth_histogram(settings, self.intrinsics, points, depth, valid)

        position = self.physics.position()
        clearance = self.physics.obstacle_clearance()
        self._min_clearance = min(self._min_clearance, clearance)
        success = bool(position[0] >= self._goal_x and not collision)
        out_of_bounds = bool(abs(position[1]) > settings.lateral_bound or position[2] > settings.max_height)
        progress = float(position[0] - x_before)
        terms = reward_terms(settings, progress, success, collision or out_of_bounds, action, clearance)
        info = {
            "collision": collision,
            "success": success,
            "out_of_bounds": out_of_bounds,
            "progress": float(position[0]),
            "clearance": clearance,
            "min_clearance": self._min_clearance,
            "position": position,
            "true_rotation": frame.true_motion[0],
            "true_translation": frame.true_motion[1],
            **estimator_info(points, true_depth),
            **terms,
        }
        observation = self._observation(histogram, points, depth, valid)
        terminated = collision or success or out_of_bounds
        return observation, float(sum(terms.values())), terminated, False, info

    def render(self) -> np.ndarray | None:
        """With ``render_mode="rgb_array"``: the camera frame with tracked points, flow vectors and depth-coloured
        circles (thesis Figs. 25–27; depths after the depth errors), beside a chase view; (240, 640, 3) uint8."""
        self._require_open("render")
        if self.render_mode != "rgb_array" or self._frame is None:
            return None
        if self._view is None:
            self._view = CameraRenderer(self.physics.model, *VIEW_PANEL_SIZE)
        points = self._depth_points
        panel = camera_panel(
            self._frame,
            points.points,
            points.next_points,
            points.depth,
            points.valid,
            max_depth=float(self.settings.depth_bin_edges[-1]),
        )
        return np.concatenate([panel, self._view.render(self.physics.data, "chase")], axis=1)

    def close(self) -> None:
        self._closed = True
        self._camera.close()
        if self._view is not None:
            self._view.close()
            self._view = None

    def _require_open(self, method: str) -> None:
        # A closed env would quietly make a new GL context; a closed env is a bug in the caller.
        if self._closed:
            raise RuntimeError(f"{method}() called on a closed FlowNavEnv; make a new env instead")

    def _render_camera(self) -> np.ndarray:
        return self._camera.render(self.physics.data, self.physics.camera_id)

    def _observation(
        self, histogram: np.ndarray, points: DepthPoints, depth: np.ndarray, counted: np.ndarray
    ) -> dict:
        state = drone_state(self.physics)
        raw = assemble_observation(self.settings, self.intrinsics, histogram, state, points, depth, counted)
        self._observed = smoothed_near(raw, self._observed, self.settings.near_smoothing)
        return self._observed
