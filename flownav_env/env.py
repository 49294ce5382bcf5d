"""FlowNav-v0: a quadcopter with a forward camera flies through capsule obstacles, seeing depth only through
optical flow."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from estimator import DepthPoints, FlowDepthEstimator
from flownav_env.actions import action_space, checked_action
from flownav_env.env_arguments import SensorSetting, Setting, with_setting_rows
from flownav_env.observation import estimator_info
from flownav_env.physics import FlowNavPhysics
from flownav_env.quadrotor import ControllerGains, QuadrotorParams
from flownav_env.rendering import VIEW_PANEL_SIZE, CameraRenderer, camera_panel
from flownav_env.scene import LayoutParams
from flownav_env.sensor import SensorPipeline
from flownav_env.settings import EnvSettings
from flownav_env.settings_check import RENDER_MODES, check_render_mode, settings_with
from flownav_env.stage_timing import StageClock, StageTimes, Untimed
from flownav_env.task import FlowNavTask

# What reset and step observe: the Observation Space's keys, each a float32 array.
Observation = dict[str, np.ndarray]


@with_setting_rows
class FlowNavEnv(gym.Env[dict[str, Any], np.ndarray]):
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
    the estimated depths (bias, drift, noise floor, outliers, dropout: :mod:`flownav_env.sensor_errors`).
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
    ``observe_approach``, and six privileged ones with ``observe_layout`` (:mod:`flownav_env.privileged`):

    | Key               | Shape                   | Range                | Meaning                                   |
    |-------------------|-------------------------|----------------------|-------------------------------------------|
    | ``depth_histogram``| (rows, cols, bins)     | [0, 1]               | per image sector (``histogram_sectors``, row 0 at the top, column 0 at the left), the fraction of its valid depth points in each depth bin (``depth_bin_edges``, m; beyond the last edge counts in the last bin); an empty sector is all zeros. Both resolutions are observation settings an agent may ask any tier for: the same depths binned otherwise, never another task (``tiers.AGENT_OBSERVATION_SETTINGS``) |
    | ``state``         | (7,)                    | see below            | what a real drone knows of itself         |
    | ``unresolved``    | (rows, cols)            | [0, 1]               | only with ``observe_unresolved=True``: per sector, the share of the tracked points that got no depth to count (too little parallax: far away, or near the focus of expansion); 0 where nothing was tracked |
    | ``point_counts``  | (rows, cols)            | [0, 1]               | only with ``observe_counts=True``: per sector, the confidence 1 − exp(−n/10) of the n points its histogram counts |
    | ``nearness``      | (rows, cols)            | [0, 1]               | only with ``observe_nearness=True``: per sector, min(1, 0.5 m / d) of a robust near depth d (``estimator.sector_near_depth``: a low quantile of its depths, never one lone point); 0 where no depth counts |
    | ``approach``      | (rows, cols)            | [0, 1]               | only with ``observe_approach=True``: per sector, min(1, 0.5 s · v / d) for the same d and the forward velocity v (0 when flying backwards): the inverse time to contact, as a bee's optic flow gives it; at 1 m/s it equals ``nearness`` |
    | ``layout``        | (64, 3)                 | [-1000, 1000]        | only with ``observe_layout=True`` (privileged: no sensor gives it): the episode's capsules as world x, y of the axis and radius (m), one row each, padded with zeros to the scene's pool of 64 (``MAX_CAPSULES``) |
    | ``layout_mask``   | (64,)                   | {0, 1}               | only with ``observe_layout=True``: 1 where a row of ``layout`` is a capsule |
    | ``true_state``    | (12,)                   | ±1000 m, ±50 m/s, angles, ±100 rad/s | only with ``observe_layout=True``: the true world position x, y, z (m), world velocity (m/s), roll, pitch, yaw (rad) and body rates (rad/s) |
    | ``course``        | (9,)                    | [0, 1000]            | only with ``observe_layout=True``: goal line x, ``lateral_bound``, ``max_height`` (m), ``forward_speed``, ``max_lateral_speed``, ``max_vertical_speed`` (m/s), ``max_yaw_rate`` (rad/s), the drone's hull radius (m) and ``frame_rate`` (Hz) |
    | ``camera``        | (15,)                   | ±1000 m, [-1, 1], ±1e5 px | only with ``observe_layout=True``: the camera's true world position (m), world-from-camera rotation in OpenCV axes row by row, and horizontal focal length, principal point and image width (px) |
    | ``depth_bin_edges``| (bins + 1,)            | [0, 1000]            | only with ``observe_layout=True``: the histogram's ``depth_bin_edges`` (m) |

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

    ## Signs
    Every sign of the observation and the action, in one place. The world is x forward along the course
    toward the goal, y to the left, z up, yaw counter-clockwise seen from above (ROS REP 103); the observation
    follows it, while the action is said in the camera image's terms, so its lateral and yaw signs are the
    opposite of the observation's.

    | Quantity | Positive means |
    |----------|----------------|
    | ``state[0]`` forward velocity | toward the goal, along the heading |
    | ``state[1]`` lateral velocity | to the left (body yaw frame) |
    | ``state[2]`` vertical velocity | up |
    | ``state[3]`` roll | right side down (counter-clockwise about the forward axis) |
    | ``state[4]`` pitch | nose down |
    | ``state[6]`` heading error | turned to the left (counter-clockwise) of the goal direction |
    | ``depth_histogram`` and the sector keys | row 0 at the top of the image, column 0 at its left |
    | ``layout``, ``true_state`` (privileged) | world x toward the goal, y to the left, z up; yaw counter-clockwise |
    | action 0, lateral velocity | to the right: the opposite sign of ``state[1]`` |
    | action 1, vertical velocity | up, as ``state[2]`` |
    | action 2, yaw rate | to the right (clockwise): the opposite sign of ``state[6]`` |

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
    2. Out of bounds: more than ``lateral_bound`` metres sideways of the course axis or above
       ``max_height`` (``info["out_of_bounds"]``), so that flying around or over the field is no solution.
    3. Goal: the drone crosses the goal line at the far end of the course, in bounds (``info["success"]``).

    The three are exclusive, in this order (``flownav_env.task.episode_outcome``): a step that collides out of
    bounds is a collision, one that reaches the goal line out of bounds is out of bounds. After termination,
    ``step`` raises until ``reset``.
    ### Truncation
    The time limit: ``max_episode_steps`` given at registration (400 steps for ``FlowNav-v0``, 40 s).

    ## Info
    ``reset`` and ``step`` return these keys in ``info``, and no others (``tests/flownav_env/test_env_info.py``):

    | Key | Returned by | Type | Meaning |
    |---|---|---|---|
    | ``collision`` | reset, step | bool | the step ended in contact (see Termination) |
    | ``success`` | reset, step | bool | the step crossed the goal line in bounds |
    | ``out_of_bounds`` | reset, step | bool | the step left the lateral or height bounds |
    | ``progress`` | reset, step | float | the drone's x (m): the distance flown toward the goal line |
    | ``clearance`` | reset, step | float | distance from the drone's centre to the nearest capsule surface (m) |
    | ``min_clearance`` | reset, step | float | the least ``clearance`` of the episode so far (m) |
    | ``points_tracked`` | reset, step | int | keypoints the estimator tracked into this frame |
    | ``points_valid`` | reset, step | int | of those, the points with a valid depth (after ``depth_dropout``) |
    | ``position`` | reset, step | (3,) float64 | the drone's world position x, y, z (m) |
    | ``true_rotation`` | step | (3, 3) float64 | the true rotation R of the camera between the last two frames |
    | ``true_translation`` | step | (3,) float64 | the true translation t of the camera (m), ``X_next = R @ X_prev + t`` |
    | ``depth_error_median`` | step, when some valid point has a true depth | float | median relative error of the valid points' depths (needs ``depth_error_info`` or an oracle ``obs_source``) |
    | ``depth_outlier_share`` | step, when some valid point has a true depth | float | share of those points off by more than 50 % of their true depth |
    | ``reward_progress`` | step | float | the reward's progress term (see Rewards) |
    | ``reward_success`` | step | float | the reward's goal term |
    | ``reward_collision`` | step | float | the reward's collision and out-of-bounds term (≤ 0) |
    | ``reward_control`` | step | float | the reward's control-cost term (≤ 0) |
    | ``reward_clearance`` | step | float | the reward's clearance term (≤ 0) |

    ## Arguments
    | Argument | Default | Meaning |
    |---|---|---|
    | ``settings`` | None | an :class:`~flownav_env.settings.EnvSettings` holding every setting below; None for the defaults. Any setting given by keyword overrides its field (with ``gymnasium.make`` the id's ``layout`` is such a keyword) |
    {setting_rows}
    | ``render_mode`` | None | ``"rgb_array"``: camera view with the flow overlay beside a chase view |

    The settings are the fields of :class:`~flownav_env.settings.EnvSettings`, which declares each one's
    default, allowed values and meaning once (the rows above are made from it); an unknown keyword raises
    ValueError naming it and the known ones. :func:`flownav_env.settings_check.check_env_kwargs` checks a
    mapping of them (a config's ``env:``) the same way without building an env.

    Between episodes, :meth:`set_sensor` and :meth:`set_course` change what training randomises. The default
    resolution (160×120) and FAST threshold (10) were measured: ``results/env_performance.md``.

    ## Version History
    * v0: initial version (FAST threshold 10 since the benchmark's second sweep; 20 before). Since 2026-11-23 the
      camera's near plane is at 5 cm (it was 1.22 m, and nearer capsules rendered hollow): results differ.
      Since 2026-12-04 the outcomes are exclusive (an episode reaching the goal line out of bounds was counted
      a success too; trajectories are unchanged) and ``step`` after termination raises.
    """

    # gymnasium.Env declares metadata as a plain attribute, which a ClassVar here would contradict for mypy.
    metadata: dict[str, Any] = {"render_modes": list(RENDER_MODES), "render_fps": 10}  # noqa: RUF012

    # Settings read through the env (``env.settings`` owns them).
    layout: Setting[str] = Setting()
    obs_source: Setting[str] = Setting()
    forward_speed: Setting[float] = Setting()
    frame_rate: Setting[float] = Setting()
    histogram_sectors: Setting[tuple[int, int]] = Setting()
    substeps: Setting[int] = Setting()
    # The sensor variables (SENSOR_FIELDS, every one; a test checks): assigning one goes through set_sensor.
    attitude_jitter_deg = SensorSetting()
    brightness = SensorSetting()
    rotation_error = SensorSetting()
    translation_error = SensorSetting()
    rotation_bias = SensorSetting()
    translation_bias = SensorSetting()
    rotation_drift = SensorSetting()
    translation_drift = SensorSetting()
    rotation_noise_deg = SensorSetting()
    translation_noise_m = SensorSetting()
    translation_noise_correlation_s = SensorSetting()
    imu_time_offset_ms = SensorSetting()
    depth_noise = SensorSetting()
    depth_outliers = SensorSetting()
    depth_dropout = SensorSetting()

    def __init__(
        self, settings: EnvSettings | None = None, render_mode: str | None = None, **overrides: object
    ) -> None:
        self.render_mode = check_render_mode(render_mode)
        self.settings = settings = settings_with(settings, overrides)
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
        self._sensor = SensorPipeline(settings.frame_rate)
        # Times the stages of every step and reset once time_stages() swaps in a StageTimes.
        self._clock: StageClock = Untimed()
        self.task = FlowNavTask(settings, self.intrinsics)
        self.observation_space = self.task.observation_space
        self.action_space = action_space()
        self._frame: np.ndarray | None = None
        self._depth_points: DepthPoints | None = None
        # Set by reset, cleared by a terminating step: a step after the end would count the end twice.
        self._episode_running = False

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
    def reset(
        self, *, seed: int | None = None, options: dict[str, object] | None = None
    ) -> tuple[Observation, dict[str, object]]:
        """Starts an episode on the layout drawn from ``seed``; ``info`` holds the keys the Info table marks
        "reset". ``options`` is accepted for Gymnasium's API and unused."""
        self._require_open("reset")
        super().reset(seed=seed)
        settings, rng, physics, clock = self.settings, self.np_random, self.physics, self._clock
        self.task.initialize_episode(physics, settings, rng)
        # The first frame is jittered too (a draw after the course's), though it tells no motion.
        physics.set_camera_mount(self._sensor.jitter(settings.sensor, rng))
        with clock.stage("render"):
            self._frame = self._camera.render(physics.data, physics.camera_id)
        motion = self._sensor.start(physics.camera_pose())
        self.estimator.reset()
        with clock.stage("estimator"):
            points = self._depth_points = self.estimator.update(self._frame, *motion.told_motion)
        observation = self.task.observe(physics, settings, points, np.zeros(0))
        self._episode_running = True
        return observation, {**self.task.start_info(physics), **estimator_info(points, np.zeros(0))}

    def step(self, action: np.ndarray) -> tuple[Observation, float, bool, bool, dict[str, object]]:
        """One camera frame: fly the action, see, estimate, observe (see the class docstring: the spaces,
        Rewards, Episode End, and Info for the keys of ``info``). Never truncates: the time limit is the
        ``TimeLimit`` wrapper's."""
        self._require_episode()
        action = checked_action(action)
        settings, rng, physics, task, clock = (
            self.settings,
            self.np_random,
            self.physics,
            self.task,
            self._clock,
        )
        x_before = physics.position()[0]
        velocity_target, yaw_rate = task.command(physics, settings, action)
        # The flight draws nothing, so a seed's draws keep their order: jitter, told motion, depth errors.
        jitter = self._sensor.jitter(settings.sensor, rng)
        with clock.stage("physics"):
            collision = physics.advance(
                velocity_target, yaw_rate, settings.substeps, camera_disturbance=jitter
            )
        with clock.stage("render"):
            self._frame = self._camera.render(physics.data, physics.camera_id)
        motion = self._sensor.motion(settings.sensor, rng, physics.camera_pose())
        with clock.stage("estimator"):
            points = self.estimator.update(self._frame, *motion.told_motion)
        points = self._depth_points = self._sensor.corrupt_points(settings, rng, points)
        true_depth = np.zeros(0)
        if settings.needs_true_depth:
            # The points are the last frame's keypoints: their rays leave from its pose (NaN: nothing hit).
            with clock.stage("ground_truth"):
                true_depth = physics.ray_depths(self.intrinsics.rays(points.points), *motion.previous_pose)
        observation = task.observe(physics, settings, points, true_depth)
        outcome = task.outcome(physics, settings, x_before, collision)
        terms = task.reward(settings, outcome, action)
        self._episode_running = not outcome.terminated
        info: dict[str, object] = {
            **outcome.info(),
            "true_rotation": motion.true_motion[0],
            "true_translation": motion.true_motion[1],
            **estimator_info(points, true_depth),
            **terms,
        }
        return observation, float(sum(terms.values())), outcome.terminated, False, info

    def render(self) -> np.ndarray | None:
        """With ``render_mode="rgb_array"``: the camera frame with tracked points, flow vectors and depth-coloured
        circles (thesis Figs. 25–27; depths after the depth errors), beside a chase view; (240, 640, 3) uint8."""
        self._require_open("render")
        points = self._depth_points
        if self.render_mode != "rgb_array" or self._frame is None or points is None:
            return None
        if self._view is None:
            self._view = CameraRenderer(self.physics.model, *VIEW_PANEL_SIZE)
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

    def _require_episode(self) -> None:
        self._require_open("step")
        if not self._episode_running:
            raise RuntimeError(
                "step() called with no episode running: the last one terminated (or none was started); "
                "call reset() first"
            )

    def _require_open(self, method: str) -> None:
        # A closed env would quietly make a new GL context; a closed env is a bug in the caller.
        if self._closed:
            raise RuntimeError(f"{method}() called on a closed FlowNavEnv; make a new env instead")

    # --- read-only views for studies and benchmarks -----------------------------------------------------------
    @property
    def last_frame(self) -> np.ndarray | None:
        """The onboard camera's RGB frame, (H, W, 3) uint8, that the estimator saw at the last ``reset`` or
        ``step``; None before the first reset. The env's own array, replaced (not overwritten) by the next
        frame: read it, do not write to it."""
        return self._frame

    @property
    def last_depth_points(self) -> DepthPoints | None:
        """The estimator's output at the last ``reset`` or ``step``, after the configured depth errors: the
        tracked points, their depths and validity, and the estimator's per-stage ``timings``; None before the
        first reset."""
        return self._depth_points

    def time_stages(self) -> StageTimes:
        """Start timing the stages of every later ``step`` and ``reset``; the live totals.

        From the first call on, ``step`` and ``reset`` add the wall time of the env's physics (``advance``,
        ``ray_depths``), onboard camera and estimator to the returned
        :class:`~flownav_env.stage_timing.StageTimes` (about 1 µs per stage); a later call returns the same
        totals. For speed benchmarks: read ``snapshot()`` before and after a step.
        """
        if not isinstance(self._clock, StageTimes):
            self._clock = StageTimes()
        return self._clock
