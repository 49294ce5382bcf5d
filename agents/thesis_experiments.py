"""The thesis's estimator experiments (§5) replayed in FlowNav, with the error figures the thesis lacked.

Five experiments, each a typed config (``configs/thesis/<name>.yaml``) and a runner returning a JSON-ready
result and writing figures:

1. ``straight``: straight flight along the optical axis toward one capsule; depth from x-flow, y-flow,
   bidirectional flow (thesis method) and triangulation (Figs. 22–24).
2. ``rotation``: pure rotations (Table 2): distance between the tracked point p2 and the derotated point p2′.
3. ``translation``: x then y translation past one capsule and past four (Figs. 33, 35).
4. ``random6dof``: a human-like random 6-DoF path in front of one capsule (Fig. 38) and the per-stage timings
   (Table 3).
5. ``three_capsule``: a recorded flight through the three-capsule scene (Figs. 41–43), base run and sweeps of
   each test variable (Appendices C–H).

Both depth methods of :class:`estimator.FlowDepthEstimator` (``"thesis"``, ``"triangulation"``) run on the same
rendered frames. Ground truth is the exact z-depth by ray casting at every keypoint.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from agents.config import field_range

METHODS = ("thesis", "triangulation")
COMPONENT_VARIANTS = ("x-flow", "y-flow")
WITHIN = 0.10
# Depths plotted up to this many metres: the scenes' obstacles stand within 10 m.
PLOT_MAX_DEPTH = 10.0


# --- configs ---------------------------------------------------------------------------------------------------
@dataclass
class ObstacleConfig:
    """A capsule standing on the ground at (x, y) with a material index (see ``scene.material_names``)."""

    x: float = field_range(-100.0, 100.0, default=5.0)
    y: float = field_range(-100.0, 100.0, default=0.0)
    material: int = field_range(0, 5, default=0)


@dataclass
class CameraConfig:
    """Camera resolution and vertical field of view."""

    width: int = field_range(16, 1280, default=640)
    height: int = field_range(16, 1280, default=480)
    fov_deg: float = field_range(10.0, 150.0, default=60.0)


def _one_capsule() -> list[ObstacleConfig]:
    return [ObstacleConfig(5.0, 0.0, 0)]


@dataclass
class ExperimentConfig:
    """Fields every experiment shares.

    Attributes:
        camera: Resolution and field of view.
        estimator: Keyword arguments of :class:`estimator.FlowDepthEstimator` other than ``method`` (both
            methods run).
        texture_seed: Seed of the procedural textures.
        seed: Seed of the playback's random numbers.
        obstacles: The capsules.
    """

    camera: CameraConfig = field(default_factory=CameraConfig)
    estimator: dict[str, Any] = field(default_factory=dict)
    texture_seed: int = field_range(0, None, default=0)
    seed: int = field_range(0, None, default=0)
    obstacles: list[ObstacleConfig] = field(default_factory=_one_capsule)

    def validate(self) -> None:
        """Check the estimator kwargs by building an estimator; raises ValueError naming the bad key."""
        from estimator import CameraIntrinsics, FlowDepthEstimator

        if "method" in self.estimator:
            raise ValueError("key 'estimator.method' is not allowed: every experiment runs both methods")
        intrinsics = CameraIntrinsics.from_fov(self.camera.width, self.camera.height, self.camera.fov_deg)
        try:
            FlowDepthEstimator(intrinsics, **self.estimator)
        except TypeError as error:
            raise ValueError(f"key 'estimator': {error}") from error
        except ValueError as error:
            raise ValueError(f"key 'estimator.{str(error).split(' ', 1)[0]}': {error}") from error


@dataclass
class StraightConfig(ExperimentConfig):
    """Experiment 1: straight flight along the optical axis (world +x) toward the capsule."""

    start: list[float] = field(default_factory=lambda: [0.0, 0.0, 1.0])
    distance_per_frame: float = field_range(0.001, 1.0, default=0.05)
    frames: int = field_range(3, 10000, default=60)


@dataclass
class RotationCase:
    """One pure rotation of Table 2: a constant rotation per frame about the camera's own axes (degrees)."""

    name: str = "case"
    pitch_deg: float = field_range(-30.0, 30.0, default=0.0)  # about the camera's x axis (right)
    yaw_deg: float = field_range(-30.0, 30.0, default=0.0)  # about the camera's y axis (down)
    roll_deg: float = field_range(-30.0, 30.0, default=0.0)  # about the optical axis


@dataclass
class RotationConfig(ExperimentConfig):
    """Experiment 2: pure rotations about the camera centre (Table 2)."""

    position: list[float] = field(default_factory=lambda: [1.0, 0.0, 1.0])
    frames_per_case: int = field_range(2, 1000, default=8)
    outlier_px: float = field_range(0.0, None, default=5.0)
    cases: list[RotationCase] = field(default_factory=lambda: [RotationCase("yaw 2 deg", yaw_deg=2.0)])


@dataclass
class SceneConfig:
    """A named set of capsules."""

    name: str = "scene"
    obstacles: list[ObstacleConfig] = field(default_factory=_one_capsule)


@dataclass
class TranslationConfig(ExperimentConfig):
    """Experiment 3: translation along the camera's x axis, then along its y axis, past each scene."""

    scenes: list[SceneConfig] = field(default_factory=lambda: [SceneConfig("one capsule")])
    start: list[float] = field(default_factory=lambda: [1.0, 1.5, 1.0])
    x_distance: float = field_range(-20.0, 20.0, default=3.0)  # along camera x (right), m
    y_distance: float = field_range(-5.0, 5.0, default=-0.6)  # along camera y (down; negative = up), m
    frames_x: int = field_range(1, 10000, default=40)
    frames_y: int = field_range(1, 10000, default=20)


@dataclass
class Random6DofConfig(ExperimentConfig):
    """Experiment 4: a smooth random 6-DoF path (sums of random sinusoids) drifting toward the capsule."""

    start: list[float] = field(default_factory=lambda: [0.0, 0.0, 1.0])
    frames: int = field_range(3, 10000, default=80)
    forward_per_frame: float = field_range(0.0, 1.0, default=0.03)
    position_amplitude_m: float = field_range(0.0, 2.0, default=0.3)
    rotation_amplitude_deg: float = field_range(0.0, 30.0, default=4.0)
    min_period_frames: float = field_range(4.0, None, default=20.0)
    max_period_frames: float = field_range(4.0, None, default=80.0)
    path_seed: int = field_range(0, None, default=0)

    def validate(self) -> None:
        """As :meth:`ExperimentConfig.validate`, plus ``min_period_frames <= max_period_frames``."""
        super().validate()
        if self.min_period_frames > self.max_period_frames:
            raise ValueError(
                f"key 'min_period_frames' must be <= max_period_frames ({self.max_period_frames}), "
                f"got {self.min_period_frames}"
            )


@dataclass
class RecordConfig:
    """The base flight of experiment 5, recorded from FlowNavEnv under a scripted sinusoidal policy."""

    env_seed: int = field_range(0, None, default=0)
    steps: int = field_range(2, 10000, default=40)
    forward_speed: float = field_range(0.1, 5.0, default=1.0)
    frame_rate: float = field_range(1.0, 50.0, default=10.0)
    lateral_action: float = field_range(0.0, 1.0, default=0.3)
    vertical_action: float = field_range(0.0, 1.0, default=0.2)
    yaw_action: float = field_range(0.0, 1.0, default=0.3)
    period_steps: float = field_range(2.0, None, default=20.0)


@dataclass
class BaseSettingsConfig:
    """The base run's test variables; each sweep changes one of them."""

    distance_per_frame: float = field_range(0.001, 10.0, default=0.05)
    brightness: float = field_range(0.0, 4.0, default=1.0)
    attitude_jitter_deg: float = field_range(0.0, 10.0, default=0.0)
    rotation_error: float = field_range(0.0, 1.0, default=0.0)
    translation_error: float = field_range(0.0, 1.0, default=0.0)
    max_frames: int = field_range(2, 10000, default=40)


@dataclass
class SweepConfig:
    """Values of each test variable (Appendices C–H); the others stay at the base run's values."""

    attitude_jitter_deg: list[float] = field_range(0.0, 10.0, default_factory=lambda: [0.0, 1.0, 2.5])
    distance_per_frame: list[float] = field_range(0.001, 10.0, default_factory=lambda: [0.005, 0.05, 0.3])
    brightness: list[float] = field_range(0.0, 4.0, default_factory=lambda: [0.5, 1.0, 2.0])
    rotation_error: list[float] = field_range(0.0, 1.0, default_factory=lambda: [0.0, 0.1])
    translation_error: list[float] = field_range(0.0, 1.0, default_factory=lambda: [0.0, 0.1])


@dataclass
class ThreeCapsuleConfig(ExperimentConfig):
    """Experiment 5: the three-capsule scene; the capsules come from the env's ``three`` layout."""

    record: RecordConfig = field(default_factory=RecordConfig)
    base: BaseSettingsConfig = field(default_factory=BaseSettingsConfig)
    sweeps: SweepConfig = field(default_factory=SweepConfig)
    obstacles: list[ObstacleConfig] = field(default_factory=list)


# --- pure kernels ----------------------------------------------------------------------------------------------
def relative_depth_errors(depth: np.ndarray, true_depth: np.ndarray) -> np.ndarray:
    """``|d - d_true| / d_true`` per point (NaN where the truth is missing or not positive)."""
    depth = np.asarray(depth, np.float64)
    true_depth = np.asarray(true_depth, np.float64)
    errors = np.full(depth.shape, np.nan)
    usable = np.isfinite(true_depth) & (true_depth > 0) & np.isfinite(depth)
    errors[usable] = np.abs(depth[usable] - true_depth[usable]) / true_depth[usable]
    return errors


def component_depth(
    normalized_prev: np.ndarray,
    normalized_next: np.ndarray,
    rotation: np.ndarray,
    translation: np.ndarray,
    focal_scale: np.ndarray,
    component: int,
) -> tuple[np.ndarray, np.ndarray]:
    """Depth from one flow component only (the thesis's x-flow / y-flow depth, Figs. 22–23).

    Derotates with the known rotation, then solves ``d' (x'_c - g_c) = t_c - x'_c t_z`` for the chosen image
    component ``c`` (0 = x, 1 = y) and returns ``d = d' / h_z``.

    Args:
        normalized_prev: (N, 2) normalised positions in the previous image.
        normalized_next: (N, 2) normalised tracked positions in the next image.
        rotation: (3, 3), ``X_next = R X_prev + t``.
        translation: (3,), m.
        focal_scale: ``[fx, fy]`` in pixels.
        component: 0 (x-flow) or 1 (y-flow).

    Returns:
        ``(depth, parallax_px)``: (N,) depths in metres (NaN where the component's flow is zero) and (N,)
        the absolute flow of that component after derotation, in pixels.

    Raises:
        ValueError: ``component`` is not 0 or 1.
    """
    from estimator.geometry import derotate

    if component not in (0, 1):
        raise ValueError(f"component must be 0 (x-flow) or 1 (y-flow), got {component!r}")
    normalized_next = np.asarray(normalized_next, np.float64).reshape(-1, 2)
    derotated, rotated_z = derotate(normalized_prev, rotation)
    flow = (normalized_next[:, component] - derotated[:, component]) * focal_scale[component]
    rhs = (translation[component] - normalized_next[:, component] * translation[2]) * focal_scale[component]
    parallax = np.nan_to_num(np.abs(flow), nan=0.0)
    depth = np.full(len(flow), np.nan)
    usable = (parallax > 1e-12) & (rotated_z > 1e-9)
    depth[usable] = rhs[usable] / flow[usable] / rotated_z[usable]
    return depth, parallax


def depth_metrics(frames: list[dict[str, np.ndarray]], obstacles_only: bool = False) -> dict[str, float]:
    """Error statistics of one method over a run.

    Args:
        frames: Per estimated frame a dict with ``depth``, ``valid``, ``true_depth``, ``labels`` (N,) arrays and
            ``tracked`` (int).
        obstacles_only: Count only points whose ground truth lies on a capsule (label >= 0).

    Returns:
        ``median_rel_error`` (median ``|d - d_true| / d_true`` over valid points with a ground truth, NaN
        without any), ``within_10pct`` (their fraction within 10 %), ``valid_per_frame`` (mean valid points per
        estimated frame), ``tracked_per_frame``, ``evaluated`` (points with a ground truth) and ``frames``.
    """
    errors, valid_counts, tracked_counts = [], [], []
    for frame in frames:
        valid = np.asarray(frame["valid"], bool)
        if obstacles_only:
            valid = valid & (np.asarray(frame["labels"]) >= 0)
        valid_counts.append(int(valid.sum()))
        tracked_counts.append(int(frame["tracked"]))
        relative = relative_depth_errors(frame["depth"][valid], frame["true_depth"][valid])
        errors.append(relative[np.isfinite(relative)])
    all_errors = np.concatenate(errors) if errors else np.zeros(0)
    count = len(all_errors)
    return {
        "median_rel_error": float(np.median(all_errors)) if count else math.nan,
        "within_10pct": float(np.mean(all_errors <= WITHIN)) if count else math.nan,
        "valid_per_frame": float(np.mean(valid_counts)) if valid_counts else 0.0,
        "tracked_per_frame": float(np.mean(tracked_counts)) if tracked_counts else 0.0,
        "evaluated": int(count),
        "frames": len(frames),
    }


def rotation_residuals(
    points: np.ndarray,
    next_points: np.ndarray,
    rotation: np.ndarray,
    intrinsics: Any,
    thesis_derotation: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Distances |p2 - p2′| (tracked minus derotated) and |p2 - p1| (no compensation), in pixels.

    Args:
        points: (N, 2) p1, keypoints in the previous image (pixels).
        next_points: (N, 2) p2, their tracked positions.
        rotation: (3, 3) rotation of the pure-rotation motion.
        intrinsics: :class:`estimator.CameraIntrinsics`.
        thesis_derotation: Derotate with the rotation rebuilt from its Z-Y-X Euler angles (thesis eq. 4.15)
            instead of the matrix itself.

    Returns:
        ``(compensated, uncompensated)``, both (N,) pixel distances.
    """
    from estimator.geometry import derotate, euler_zyx_to_rotation, rotation_to_euler_zyx

    if thesis_derotation:
        rotation = euler_zyx_to_rotation(*rotation_to_euler_zyx(rotation))
    derotated, _ = derotate(intrinsics.normalize(points), rotation)
    predicted = intrinsics.denormalize(derotated)
    next_points = np.asarray(next_points, np.float64)
    compensated = np.linalg.norm(next_points - predicted, axis=1)
    uncompensated = np.linalg.norm(next_points - np.asarray(points, np.float64), axis=1)
    return compensated, uncompensated


# --- scripted paths -------------------------------------------------------------------------------------------
def _scene(config: ExperimentConfig, obstacles: Iterable[ObstacleConfig] | None = None) -> dict[str, Any]:
    obstacles = list(config.obstacles if obstacles is None else obstacles)
    return {
        "obstacles": np.array([[o.x, o.y] for o in obstacles], np.float64).reshape(-1, 2),
        "materials": np.array([o.material for o in obstacles], np.int64),
        "texture_seed": config.texture_seed,
    }


def _vector3(name: str, values: list[float]) -> np.ndarray:
    array = np.asarray(values, np.float64)
    if array.shape != (3,) or not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be three finite numbers [x, y, z] in metres, got {values!r}")
    return array


def straight_path(config: StraightConfig) -> Any:
    """Experiment 1's path: level camera looking along +x, moving ``distance_per_frame`` along +x per frame."""
    from flownav_env.recording import camera_rotation, path_from_poses

    start = _vector3("start", config.start)
    steps = np.arange(config.frames)[:, None] * config.distance_per_frame
    positions = start + steps * np.array([1.0, 0.0, 0.0])
    rotations = np.repeat(camera_rotation(0.0)[None], config.frames, axis=0)
    return path_from_poses(rotations, positions, 10.0, **_scene(config))


def rotation_path(config: RotationConfig, case: RotationCase) -> Any:
    """Experiment 2's path for one case: a fixed camera centre turning by the case's rotation each frame."""
    from flownav_env.recording import camera_rotation, path_from_poses
    from flownav_env.sensor import rotation_from_vector

    position = _vector3("position", config.position)
    rate = np.deg2rad([case.pitch_deg, case.yaw_deg, case.roll_deg])
    rotations = np.array(
        [camera_rotation(0.0, rotation_from_vector(k * rate)) for k in range(config.frames_per_case)]
    )
    positions = np.repeat(position[None], config.frames_per_case, axis=0)
    return path_from_poses(rotations, positions, 10.0, **_scene(config))


def translation_path(config: TranslationConfig, scene: SceneConfig) -> tuple[Any, int]:
    """Experiment 3's path: along the camera's x axis, then its y axis; returns (path, index of the turn)."""
    from flownav_env.recording import camera_rotation, path_from_poses

    start = _vector3("start", config.start)
    rotation = camera_rotation(0.0)
    x_steps = np.linspace(0.0, config.x_distance, config.frames_x + 1)
    y_steps = np.linspace(0.0, config.y_distance, config.frames_y + 1)[1:]
    corner = start + rotation[:, 0] * config.x_distance
    positions = np.concatenate(
        [start + x_steps[:, None] * rotation[:, 0], corner + y_steps[:, None] * rotation[:, 1]]
    )
    rotations = np.repeat(rotation[None], len(positions), axis=0)
    return path_from_poses(rotations, positions, 10.0, **_scene(config, scene.obstacles)), config.frames_x


def random_6dof_path(config: Random6DofConfig) -> Any:
    """Experiment 4's path: forward drift plus, per axis, a sum of three random sinusoids (human-like sway).

    Raises:
        ValueError: ``min_period_frames`` exceeds ``max_period_frames``.
    """
    from flownav_env.recording import camera_rotation, path_from_poses
    from flownav_env.sensor import rotation_from_vector

    if config.min_period_frames > config.max_period_frames:
        raise ValueError(
            f"min_period_frames ({config.min_period_frames}) must be <= max_period_frames "
            f"({config.max_period_frames})"
        )
    rng = np.random.default_rng(config.path_seed)
    frames = np.arange(config.frames)

    def sway(amplitude: float) -> np.ndarray:
        periods = rng.uniform(config.min_period_frames, config.max_period_frames, 3)
        phases = rng.uniform(0.0, 2 * np.pi, 3)
        weights = rng.dirichlet(np.ones(3))
        # Starting every sinusoid from its value at frame 0 keeps the first pose at the start.
        waves = np.sin(2 * np.pi * frames[:, None] / periods + phases) - np.sin(phases)
        return amplitude * waves @ weights

    start = _vector3("start", config.start)
    offsets = np.column_stack(
        [
            frames * config.forward_per_frame + sway(config.position_amplitude_m) * 0.3,
            sway(config.position_amplitude_m),
            sway(config.position_amplitude_m),
        ]
    )
    angles = np.deg2rad(np.column_stack([sway(config.rotation_amplitude_deg) for _ in range(3)]))
    rotations = np.array([camera_rotation(0.0, rotation_from_vector(a)) for a in angles])
    return path_from_poses(rotations, start + offsets, 30.0, **_scene(config))


def record_three_capsule_flight(config: ThreeCapsuleConfig) -> Any:
    """Experiment 5's base path: FlowNavEnv's ``three`` layout flown under a scripted sinusoidal policy."""
    from flownav_env import FlowNavEnv
    from flownav_env.recording import record_env_flight

    record = config.record
    env = FlowNavEnv(
        layout="three",
        forward_speed=record.forward_speed,
        frame_rate=record.frame_rate,
        camera_width=32,
        camera_height=24,
        texture_seed=config.texture_seed,
    )

    def policy(_observation: Any, step: int) -> np.ndarray:
        phase = 2 * np.pi * step / record.period_steps
        return np.array(
            [
                record.lateral_action * math.sin(phase),
                record.vertical_action * math.sin(0.7 * phase),
                record.yaw_action * math.sin(0.5 * phase),
            ]
        )

    try:
        return record_env_flight(
            env, policy, record.steps, seed=record.env_seed, texture_seed=config.texture_seed
        )
    finally:
        env.close()


# --- playback + estimation -------------------------------------------------------------------------------------
@dataclass
class RunResult:
    """One playback through both estimators.

    Attributes:
        methods: Per method (and x-flow / y-flow variants) the per-frame dicts of :func:`depth_metrics`, each
            with ``points`` too.
        references: (frames - 1, M) ground-truth z-depth of each capsule's surface facing the camera (at the
            camera's height on the capsule's axis), NaN where off-screen or hidden; one row per estimated frame.
        timings: Per method, per stage, the per-frame seconds (``DepthPoints.timings``).
        render_s: Seconds per rendered frame.
        residuals: For pure rotations, per frame the tracked points' p1, p2 and tracked mask (thesis
            estimator), and the told rotation.
    """

    methods: dict[str, list[dict[str, Any]]] = field(default_factory=dict)
    references: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    timings: dict[str, dict[str, list[float]]] = field(default_factory=dict)
    render_s: list[float] = field(default_factory=list)
    residuals: list[dict[str, np.ndarray]] = field(default_factory=list)


def _reference_depths(world: Any, intrinsics: Any, rotation: np.ndarray, position: np.ndarray) -> np.ndarray:
    # The line the thesis plots each obstacle against: the capsule surface straight in front of its axis, at
    # the camera's height, where that point is in view and not hidden behind another capsule.
    layout = world.layout
    axis_z = np.clip(position[2], layout.obstacle_radius, layout.obstacle_height - layout.obstacle_radius)
    depths = np.full(len(world.obstacles), np.nan)
    for k, (x, y) in enumerate(world.obstacles):
        camera_point = rotation.T @ (np.array([x, y, axis_z]) - position)
        if camera_point[2] <= 0:
            continue
        ray = np.array([camera_point[0] / camera_point[2], camera_point[1] / camera_point[2], 1.0])
        pixel = intrinsics.denormalize(ray[None, :2])[0]
        if not (0 <= pixel[0] <= intrinsics.width - 1 and 0 <= pixel[1] <= intrinsics.height - 1):
            continue
        depth = world.true_depth(ray[None], rotation, position)
        hit = position + rotation @ (ray * depth[0])
        if np.isfinite(depth[0]) and world.label_points(hit[None])[0] == k:
            depths[k] = depth[0]
    return depths


def run_playback(
    path: Any,
    world: Any,
    settings: Any,
    estimator_kwargs: dict[str, Any],
    *,
    component_variants: bool = False,
    keep_residuals: bool = False,
    progress: bool = True,
    description: str = "",
) -> RunResult:
    """Play a path back through the renderer into both estimators and compare every depth with the truth.

    Args:
        path: :class:`flownav_env.recording.CameraPath`.
        world: :class:`flownav_env.recording.PlaybackWorld` built from the path.
        settings: :class:`flownav_env.recording.PlaybackSettings`.
        estimator_kwargs: :class:`estimator.FlowDepthEstimator` kwargs (without ``method``).
        component_variants: Also compute x-flow-only and y-flow-only depths from the thesis estimator's tracks.
        keep_residuals: Keep p1, p2 and the told rotation per frame (pure-rotation analysis).
        progress: Show a tqdm progress bar.
        description: Label of the progress bar.

    Returns:
        A :class:`RunResult`.
    """
    from tqdm import tqdm

    from estimator import CameraIntrinsics, FlowDepthEstimator
    from estimator.geometry import solve_depth, valid_depth_mask
    from flownav_env.recording import play_back

    intrinsics = CameraIntrinsics.from_fov(world.width, world.height, world.fov_deg)
    estimators = {m: FlowDepthEstimator(intrinsics, method=m, **estimator_kwargs) for m in METHODS}
    reference = estimators["thesis"]
    names = list(METHODS) + (list(COMPONENT_VARIANTS) if component_variants else [])
    result = RunResult(methods={name: [] for name in names}, timings={m: {} for m in METHODS})
    references = []
    previous_pose = None
    if settings.distance_per_frame is not None:
        total = math.floor(path.arc_length()[-1] / settings.distance_per_frame + 1e-9) + 1
    else:
        total = len(path)
    if settings.max_frames is not None:
        total = min(total, settings.max_frames)
    frames = play_back(path, world, settings)
    bar = tqdm(total=total, desc=description, disable=not progress, leave=False)
    while True:
        # Timed by hand around next(): the generator places the camera and renders inside it.
        start = time.perf_counter()
        frame = next(frames, None)
        if frame is None:
            break
        result.render_s.append(time.perf_counter() - start)
        bar.update()
        image = frame.image
        told_rotation, told_translation = frame.told_motion
        outputs = {m: estimators[m].update(image, told_rotation, told_translation) for m in METHODS}
        if previous_pose is None:
            previous_pose = (frame.rotation, frame.position)
            continue
        rotation_prev, position_prev = previous_pose
        references.append(_reference_depths(world, intrinsics, rotation_prev, position_prev))
        truth_cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

        def truth(
            points: np.ndarray, rotation_prev=rotation_prev, position_prev=position_prev, cache=truth_cache
        ):
            key = points.tobytes()
            if key not in cache:
                rays = np.column_stack([intrinsics.normalize(points), np.ones(len(points))])
                depth = world.true_depth(rays, rotation_prev, position_prev)
                hits = position_prev + (rays * depth[:, None]) @ rotation_prev.T
                cache[key] = (depth, world.label_points(hits))
            return cache[key]

        for method, points in outputs.items():
            true_depth, labels = truth(points.points)
            result.methods[method].append(
                {
                    "points": points.points,
                    "depth": points.depth,
                    "valid": points.valid,
                    "true_depth": true_depth,
                    "labels": labels,
                    "tracked": points.num_tracked,
                }
            )
            for stage, seconds in points.timings.items():
                result.timings[method].setdefault(stage, []).append(seconds)
        thesis_points = outputs["thesis"]
        if component_variants:
            normalized_prev = intrinsics.normalize(thesis_points.points)
            normalized_next = intrinsics.normalize(thesis_points.next_points)
            true_depth, labels = truth(thesis_points.points)
            # The epipolar check of the full solution guards the single-component depths against mistracks.
            full = solve_depth(
                normalized_prev, normalized_next, told_rotation, told_translation, intrinsics.focal_scale
            )
            epipolar_ok = valid_depth_mask(full, 0.0, reference.max_epipolar_error_px)
            for component, name in enumerate(COMPONENT_VARIANTS):
                depth, parallax = component_depth(
                    normalized_prev,
                    normalized_next,
                    told_rotation,
                    told_translation,
                    intrinsics.focal_scale,
                    component,
                )
                with np.errstate(invalid="ignore"):
                    valid = (
                        thesis_points.tracked
                        & epipolar_ok
                        & (parallax >= reference.min_parallax_px)
                        & np.isfinite(depth)
                        & (depth > 0)
                    )
                result.methods[name].append(
                    {
                        "points": thesis_points.points,
                        "depth": depth,
                        "valid": valid,
                        "true_depth": true_depth,
                        "labels": labels,
                        "tracked": thesis_points.num_tracked,
                    }
                )
        if keep_residuals:
            result.residuals.append(
                {
                    "points": thesis_points.points,
                    "next_points": thesis_points.next_points,
                    "tracked": thesis_points.tracked,
                    "rotation": told_rotation,
                }
            )
        previous_pose = (frame.rotation, frame.position)
    bar.close()
    result.references = np.asarray(references).reshape(len(references), len(world.obstacles))
    return result


# --- figures ---------------------------------------------------------------------------------------------------
_OBSTACLE_COLOURS = ("tab:red", "tab:blue", "tab:green", "tab:orange", "tab:purple", "tab:brown")


def plot_depth_panel(ax: Any, frames: list[dict[str, Any]], references: np.ndarray, title: str) -> None:
    """The thesis's plot style: each valid point's depth per frame, against each obstacle's true depth line.

    Points on a capsule take the capsule's colour; ground points are grey. Lines are the ground truth.
    """
    for index, frame in enumerate(frames):
        valid = np.asarray(frame["valid"], bool)
        labels = np.asarray(frame["labels"])
        depth = np.asarray(frame["depth"])
        ground = valid & (labels < 0)
        if ground.any():
            ax.scatter(np.full(ground.sum(), index), depth[ground], s=2, c="0.7", linewidths=0)
        for k in range(references.shape[1] if references.ndim == 2 else 0):
            on = valid & (labels == k)
            if on.any():
                colour = _OBSTACLE_COLOURS[k % len(_OBSTACLE_COLOURS)]
                ax.scatter(np.full(on.sum(), index), depth[on], s=3, c=colour, linewidths=0)
    if references.size:
        for k in range(references.shape[1]):
            colour = _OBSTACLE_COLOURS[k % len(_OBSTACLE_COLOURS)]
            ax.plot(
                np.arange(len(references)),
                references[:, k],
                c=colour,
                lw=1.5,
                label=f"capsule {k + 1} (truth)",
            )
    ax.set_ylim(0.0, PLOT_MAX_DEPTH)
    ax.set_xlabel("frame")
    ax.set_ylabel("depth (m)")
    ax.set_title(title, fontsize=9)
    ax.grid(alpha=0.3)


def save_depth_figure(
    panels: list[tuple[str, list[dict[str, Any]], np.ndarray]],
    file: Path,
    suptitle: str,
    columns: int = 2,
    marks: dict[int, float] | None = None,
) -> Path:
    """A figure of :func:`plot_depth_panel` panels; ``marks`` draws a dashed line at a frame in some panels."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = math.ceil(len(panels) / columns)
    fig, axes = plt.subplots(rows, columns, figsize=(5.0 * columns, 3.4 * rows), squeeze=False)
    for index, (ax, (title, frames, references)) in enumerate(zip(axes.flat, panels, strict=False)):
        plot_depth_panel(ax, frames, references, title)
        if marks and index in marks:
            ax.axvline(marks[index], c="k", ls="--", lw=0.8)
    for ax in list(axes.flat)[len(panels) :]:
        ax.axis("off")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="lower center", ncol=min(len(handles), 4), fontsize=8)
    fig.suptitle(suptitle, fontsize=10)
    fig.tight_layout(rect=(0, 0.05, 1, 0.97))
    file.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(file, dpi=110)
    plt.close(fig)
    return file


# --- experiments -----------------------------------------------------------------------------------------------
def _settings(config: ExperimentConfig, **kwargs: Any) -> Any:
    from flownav_env.recording import PlaybackSettings

    return PlaybackSettings(seed=config.seed, **kwargs)


def _world(path: Any, config: ExperimentConfig) -> Any:
    from flownav_env.recording import PlaybackWorld

    return PlaybackWorld(path, config.camera.width, config.camera.height, config.camera.fov_deg)


def _metric_rows(run: str, result: RunResult, names: Iterable[str]) -> list[dict[str, Any]]:
    rows = []
    for name in names:
        frames = result.methods[name]
        row = {"run": run, "method": name, **depth_metrics(frames)}
        obstacle = depth_metrics(frames, obstacles_only=True)
        row["obstacle_median_rel_error"] = obstacle["median_rel_error"]
        row["obstacle_valid_per_frame"] = obstacle["valid_per_frame"]
        rows.append(row)
    return rows


def run_straight(config: StraightConfig, out_dir: Path, progress: bool = True) -> dict[str, Any]:
    """Experiment 1 (Figs. 22–24): straight flight toward one capsule; four depth variants."""
    path = straight_path(config)
    world = _world(path, config)
    try:
        result = run_playback(
            path,
            world,
            _settings(config),
            config.estimator,
            component_variants=True,
            progress=progress,
            description="straight",
        )
    finally:
        world.close()
    names = ["x-flow", "y-flow", "thesis", "triangulation"]
    titles = {
        "x-flow": "x-flow only (Fig. 22)",
        "y-flow": "y-flow only (Fig. 23)",
        "thesis": "bidirectional, larger component (thesis method, Fig. 24)",
        "triangulation": "triangulation (both components, least squares)",
    }
    figure = save_depth_figure(
        [(titles[n], result.methods[n], result.references) for n in names],
        out_dir / "straight.png",
        f"Straight flight toward one capsule, {config.distance_per_frame} m/frame",
    )
    return {"rows": _metric_rows("straight", result, names), "figures": [figure.name]}


def run_rotation(config: RotationConfig, out_dir: Path, progress: bool = True) -> dict[str, Any]:
    """Experiment 2 (Table 2): pure rotations; residual distance after rotation compensation."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from estimator import CameraIntrinsics

    intrinsics = CameraIntrinsics.from_fov(config.camera.width, config.camera.height, config.camera.fov_deg)
    table = []
    world = None
    try:
        for case in config.cases:
            path = rotation_path(config, case)
            if world is None:
                world = _world(path, config)
            result = run_playback(
                path,
                world,
                _settings(config),
                config.estimator,
                keep_residuals=True,
                progress=progress,
                description=f"rotation {case.name}",
            )
            row: dict[str, Any] = {"case": case.name}
            for label, thesis_derotation in (("matrix", False), ("euler", True)):
                compensated, uncompensated, detected = [], [], 0
                for frame in result.residuals:
                    tracked = np.asarray(frame["tracked"], bool)
                    detected += len(tracked)
                    c, u = rotation_residuals(
                        frame["points"][tracked],
                        frame["next_points"][tracked],
                        frame["rotation"],
                        intrinsics,
                        thesis_derotation,
                    )
                    compensated.append(c)
                    uncompensated.append(u)
                c = np.concatenate(compensated) if compensated else np.zeros(0)
                u = np.concatenate(uncompensated) if uncompensated else np.zeros(0)
                inliers = c <= config.outlier_px
                row[f"{label}_mean_px"] = float(c.mean()) if len(c) else math.nan
                row[f"{label}_mean_inliers_px"] = float(c[inliers].mean()) if inliers.any() else math.nan
                row[f"{label}_outliers"] = int((~inliers).sum())
                row["uncompensated_mean_px"] = float(u.mean()) if len(u) else math.nan
                row["detected"] = detected
                row["tracked"] = len(c)
            row["frame_pairs"] = len(result.residuals)
            table.append(row)
    finally:
        if world is not None:
            world.close()
    fig, ax = plt.subplots(figsize=(9, 3.6))
    x = np.arange(len(table))
    ax.bar(x - 0.2, [r["matrix_mean_px"] for r in table], 0.4, label="incl. outliers")
    ax.bar(
        x + 0.2,
        [r["matrix_mean_inliers_px"] for r in table],
        0.4,
        label=f"excl. outliers (> {config.outlier_px:g} px)",
    )
    ax.set_xticks(x, [r["case"] for r in table], rotation=30, ha="right", fontsize=8)
    ax.set_ylabel("mean |p2 - p2′| (px)")
    ax.set_title("Rotation compensation on pure rotations (Table 2)", fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    out_dir.mkdir(parents=True, exist_ok=True)
    fig.savefig(out_dir / "rotation.png", dpi=110)
    plt.close(fig)
    return {"table2": table, "rows": [], "figures": ["rotation.png"]}


def run_translation(config: TranslationConfig, out_dir: Path, progress: bool = True) -> dict[str, Any]:
    """Experiment 3 (Figs. 33, 35): x then y translation past each scene's capsules."""
    rows, panels, marks = [], [], {}
    for scene in config.scenes:
        path, turn = translation_path(config, scene)
        world = _world(path, config)
        try:
            result = run_playback(
                path,
                world,
                _settings(config),
                config.estimator,
                progress=progress,
                description=f"translation {scene.name}",
            )
        finally:
            world.close()
        rows += _metric_rows(scene.name, result, METHODS)
        for method in METHODS:
            marks[len(panels)] = turn - 0.5
            panels.append((f"{scene.name}: {method}", result.methods[method], result.references))
    figure = save_depth_figure(
        panels, out_dir / "translation.png", "x translation, then y translation (dashed: the turn)"
    )
    return {"rows": rows, "figures": [figure.name]}


def run_random6dof(config: Random6DofConfig, out_dir: Path, progress: bool = True) -> dict[str, Any]:
    """Experiment 4 (Fig. 38, Table 3): random 6-DoF path; depth errors and per-stage timings."""
    path = random_6dof_path(config)
    world = _world(path, config)
    try:
        result = run_playback(
            path, world, _settings(config), config.estimator, progress=progress, description="random6dof"
        )
    finally:
        world.close()
    figure = save_depth_figure(
        [(method, result.methods[method], result.references) for method in METHODS],
        out_dir / "random6dof.png",
        "Human-like random 6-DoF path in front of one capsule",
    )
    timings = []
    for method in METHODS:
        for stage, seconds in result.timings[method].items():
            values = np.asarray(seconds) * 1e3
            timings.append(
                {
                    "method": method,
                    "stage": stage,
                    "mean_ms": float(values.mean()),
                    "median_ms": float(np.median(values)),
                }
            )
    render = np.asarray(result.render_s) * 1e3
    timings.append(
        {
            "method": "-",
            "stage": "render (MuJoCo)",
            "mean_ms": float(render.mean()),
            "median_ms": float(np.median(render)),
        }
    )
    return {"rows": _metric_rows("random6dof", result, METHODS), "table3": timings, "figures": [figure.name]}


# The issue maps these five variables onto Appendices C–H as a group, not one by one, so no letter is given.
SWEEP_VARIABLES = (
    ("attitude_jitter_deg", "angular instability (deg per frame)"),
    ("distance_per_frame", "distance per frame (m)"),
    ("brightness", "brightness (1 = daylight)"),
    ("rotation_error", "rotation error (relative)"),
    ("translation_error", "translation error (relative)"),
)


def run_three_capsule(config: ThreeCapsuleConfig, out_dir: Path, progress: bool = True) -> dict[str, Any]:
    """Experiment 5 (Figs. 41–43, Appendices C–H): recorded flight, base run, one sweep per variable."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from flownav_env.recording import save_path

    path = record_three_capsule_flight(config)
    if config.obstacles:
        # An explicit capsule list in the config overrides the env layout's capsules for the playback.
        scene = _scene(config)
        path.obstacles, path.materials = scene["obstacles"], scene["materials"]
    save_path(path, out_dir / "three_capsule_path.npz")
    base = {
        "distance_per_frame": config.base.distance_per_frame,
        "brightness": config.base.brightness,
        "attitude_jitter_deg": config.base.attitude_jitter_deg,
        "rotation_error": config.base.rotation_error,
        "translation_error": config.base.translation_error,
        "max_frames": config.base.max_frames,
    }
    world = _world(path, config)
    rows, sweeps = [], []
    try:
        base_result = run_playback(
            path,
            world,
            _settings(config, **base),
            config.estimator,
            progress=progress,
            description="three base",
        )
        rows += _metric_rows("base", base_result, METHODS)
        for variable, _label in SWEEP_VARIABLES:
            for value in getattr(config.sweeps, variable):
                settings = {**base, variable: value}
                distance = settings["distance_per_frame"]
                if distance > path.arc_length()[-1]:
                    continue
                result = run_playback(
                    path,
                    world,
                    _settings(config, **settings),
                    config.estimator,
                    progress=progress,
                    description=f"{variable}={value:g}",
                )
                for row in _metric_rows(f"{variable}={value:g}", result, METHODS):
                    sweeps.append({"variable": variable, "value": value, **row})
    finally:
        world.close()
    base_figure = save_depth_figure(
        [(method, base_result.methods[method], base_result.references) for method in METHODS],
        out_dir / "three_capsule_base.png",
        f"Three capsules, base run ({config.base.distance_per_frame} m/frame)",
    )
    fig, axes = plt.subplots(
        2, len(SWEEP_VARIABLES), figsize=(3.4 * len(SWEEP_VARIABLES), 5.6), squeeze=False
    )
    for column, (variable, label) in enumerate(SWEEP_VARIABLES):
        for method, marker in zip(METHODS, ("o", "s"), strict=True):
            points = [r for r in sweeps if r["variable"] == variable and r["method"] == method]
            values = [r["value"] for r in points]
            axes[0, column].plot(
                values, [100 * r["median_rel_error"] for r in points], marker=marker, label=method
            )
            axes[1, column].plot(values, [r["valid_per_frame"] for r in points], marker=marker, label=method)
        axes[0, column].set_title(label, fontsize=8)
        axes[1, column].set_xlabel(label, fontsize=8)
        if variable == "distance_per_frame":
            axes[0, column].set_xscale("log")
            axes[1, column].set_xscale("log")
        for row in range(2):
            axes[row, column].grid(alpha=0.3)
    axes[0, 0].set_ylabel("median |rel. depth error| (%)")
    axes[1, 0].set_ylabel("valid points per frame")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle("Three capsules: one test variable changed from the base run (Appendices C–H)", fontsize=10)
    fig.tight_layout()
    fig.savefig(out_dir / "three_capsule_sweeps.png", dpi=110)
    plt.close(fig)
    return {
        "rows": rows,
        "sweeps": sweeps,
        "figures": [base_figure.name, "three_capsule_sweeps.png"],
        "recorded_frames": len(path),
        "recorded_length_m": float(path.arc_length()[-1]),
        "obstacles": path.obstacles.tolist(),
    }


@dataclass(frozen=True)
class Experiment:
    """An experiment: its config schema, runner and what the thesis showed."""

    name: str
    title: str
    schema: type
    runner: Callable[..., dict[str, Any]]
    thesis: str


EXPERIMENTS: dict[str, Experiment] = {
    e.name: e
    for e in (
        Experiment(
            "straight",
            "1. Straight flight toward one capsule (Figs. 22–24)",
            StraightConfig,
            run_straight,
            "Figs. 22–24 plot per-frame depths from x-flow, y-flow and bidirectional flow against the truth.",
        ),
        Experiment(
            "rotation",
            "2. Rotation compensation on pure rotations (Table 2)",
            RotationConfig,
            run_rotation,
            "Table 2 lists, for nine pure-rotation cases, the mean distance p1–p2′ including and excluding "
            "outliers (> 5 px) and the point counts.",
        ),
        Experiment(
            "translation",
            "3. x then y translation past one and four capsules (Figs. 33, 35)",
            TranslationConfig,
            run_translation,
            "Figs. 33 and 35 plot per-frame depths for x then y translation past one capsule and past four.",
        ),
        Experiment(
            "random6dof",
            "4. Human-like random 6-DoF path (Fig. 38) and performance (Table 3)",
            Random6DofConfig,
            run_random6dof,
            "Fig. 38 plots per-frame depths on a random 6-DoF path; Table 3 gives the estimator's run time.",
        ),
        Experiment(
            "three_capsule",
            "5. Three-capsule scene and its test variables (Figs. 41–43, Appendices C–H)",
            ThreeCapsuleConfig,
            run_three_capsule,
            "Figs. 41–43 and Appendices C–H plot per-frame depths in the three-capsule scene for the base run and "
            "for angular instability, distance per frame, brightness, rotation error and translation error.",
        ),
    )
}
