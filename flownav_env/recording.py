"""Record and play back camera paths through the FlowNav scene (the thesis's record and playback modes, §3.4–3.5).

A :class:`CameraPath` is a sequence of camera poses plus the frame rate and the scene it was recorded in. It
comes from a scripted path (:func:`path_from_poses`) or from a flight of the Gymnasium env
(:func:`record_env_flight`), is saved to and loaded from an NPZ file (:func:`save_path`, :func:`load_path`),
and is played back through the renderer (:func:`play_back`) under changed test variables
(:class:`PlaybackSettings`): brightness, distance per frame (the path resampled by interpolation, slerp for
the rotations, as the thesis did), camera attitude jitter, and rotation/translation errors of the motion
told to the estimator. Playback is deterministic for a seed.

File format (NPZ, ``numpy.savez``; every array float64 unless noted):

========================  ==========  =====================================================================
key                       shape       meaning
========================  ==========  =====================================================================
``format``                ()          str ``"flownav-camera-path"``
``version``               ()          int64, 1
``times``                 (N,)        seconds since the first frame, strictly increasing
``positions``             (N, 3)      camera position in the world, m (world: x forward, y left, z up)
``quaternions``           (N, 4)      world-from-camera rotation as a unit quaternion ``(w, x, y, z)``,
                                      camera axes OpenCV (x right, y down, z forward)
``frame_rate``            ()          frames per second of the recording, Hz
``obstacles``             (M, 2)      capsule centres (x, y) in the world, m
``materials``             (M,)        int64 material index of each capsule (see ``scene.material_names``)
``texture_seed``          ()          int64 seed of the procedural textures
``obstacle_radius``       ()          capsule radius, m
``obstacle_height``       ()          capsule height, m
========================  ==========  =====================================================================

Pure kernels (quaternions, slerp, resampling) are plain numpy; MuJoCo is touched only by
:class:`PlaybackWorld` and :func:`record_env_flight`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from flownav_env.camera import MUJOCO_FROM_OPENCV, relative_motion
from flownav_env.sensor import corrupt_motion, jitter_rotation

FORMAT_NAME = "flownav-camera-path"
FORMAT_VERSION = 1
_QUAT_NORM_TOLERANCE = 1e-6


# --- pure kernels ---------------------------------------------------------------------------------------------
def quat_from_matrix(rotation: np.ndarray) -> np.ndarray:
    """Unit quaternion ``(w, x, y, z)`` with ``w >= 0`` of a rotation matrix (Shepperd's method).

    Args:
        rotation: (3, 3) rotation matrix, or (N, 3, 3).

    Returns:
        (4,) or (N, 4) float64 quaternions.
    """
    matrices = np.asarray(rotation, np.float64).reshape(-1, 3, 3)
    quats = np.empty((len(matrices), 4))
    for i, m in enumerate(matrices):
        trace = m[0, 0] + m[1, 1] + m[2, 2]
        # Branch on the largest diagonal term so the square root never sees a tiny, cancellation-prone value.
        if trace > 0.0:
            s = 2.0 * math.sqrt(1.0 + trace)
            q = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
        elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
            s = 2.0 * math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
            q = [(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
        elif m[1, 1] > m[2, 2]:
            s = 2.0 * math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
            q = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s]
        else:
            s = 2.0 * math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
            q = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s]
        q = np.asarray(q)
        q /= np.linalg.norm(q)
        quats[i] = -q if q[0] < 0 else q
    return quats[0] if np.ndim(rotation) == 2 else quats


def matrix_from_quat(quaternion: np.ndarray) -> np.ndarray:
    """Rotation matrix of a quaternion ``(w, x, y, z)`` (normalised first); (4,) → (3, 3), (N, 4) → (N, 3, 3)."""
    q = np.asarray(quaternion, np.float64)
    single = q.ndim == 1
    q = q.reshape(-1, 4)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = q.T
    matrices = np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1),
        ],
        axis=-2,
    )
    return matrices[0] if single else matrices


def slerp(q0: np.ndarray, q1: np.ndarray, fraction: np.ndarray | float) -> np.ndarray:
    """Spherical linear interpolation between unit quaternions along the shorter arc.

    Args:
        q0: (4,) or (N, 4) start quaternions ``(w, x, y, z)``.
        q1: Same shape, end quaternions.
        fraction: Scalar or (N,) interpolation parameter in [0, 1]; 0 gives ``q0``, 1 gives ``q1`` (up to sign).

    Returns:
        Interpolated unit quaternions, the shape of ``q0``.
    """
    a = np.atleast_2d(np.asarray(q0, np.float64))
    b = np.atleast_2d(np.asarray(q1, np.float64)).copy()
    u = np.broadcast_to(np.asarray(fraction, np.float64), (len(a),))[:, None]
    dot = np.sum(a * b, axis=1, keepdims=True)
    # q and -q are the same rotation: flip one so the interpolation takes the short way round.
    b = np.where(dot < 0.0, -b, b)
    dot = np.abs(dot)
    angle = np.arccos(np.clip(dot, -1.0, 1.0))
    sin_angle = np.sin(angle)
    # Nearly equal quaternions: the slerp weights are 0/0; linear interpolation is exact to first order there.
    close = sin_angle < 1e-9
    safe_sin = np.where(close, 1.0, sin_angle)
    w0 = np.where(close, 1.0 - u, np.sin((1.0 - u) * angle) / safe_sin)
    w1 = np.where(close, u, np.sin(u * angle) / safe_sin)
    result = w0 * a + w1 * b
    result /= np.linalg.norm(result, axis=1, keepdims=True)
    return result[0] if np.ndim(q0) == 1 else result


def camera_rotation(heading: float, local: np.ndarray | None = None) -> np.ndarray:
    """World-from-camera rotation (OpenCV axes) of a level camera looking along world heading ``heading``.

    Args:
        heading: Angle in radians of the viewing direction in the world's horizontal plane, counter-clockwise
            from +x (0 looks along +x).
        local: Optional (3, 3) extra rotation in the camera's own axes (applied after levelling), e.g.
            :func:`flownav_env.sensor.rotation_from_vector` of roll/pitch/yaw offsets.

    Returns:
        (3, 3) rotation whose columns are the camera's x (right), y (down) and z (forward) axes in the world.
    """
    forward = np.array([math.cos(heading), math.sin(heading), 0.0])
    right = np.array([math.sin(heading), -math.cos(heading), 0.0])
    down = np.array([0.0, 0.0, -1.0])
    level = np.column_stack([right, down, forward])
    return level if local is None else level @ np.asarray(local, np.float64)


# --- the recorded path ----------------------------------------------------------------------------------------
@dataclass
class CameraPath:
    """A recorded camera path and the scene it was recorded in (see the module docstring for the file format).

    Attributes:
        times: (N,) seconds since the first frame, strictly increasing, N >= 2.
        positions: (N, 3) camera positions in the world, m.
        quaternions: (N, 4) world-from-camera rotations ``(w, x, y, z)``, OpenCV camera axes, unit norm.
        frame_rate: Frames per second, > 0.
        obstacles: (M, 2) capsule centres (x, y), m.
        materials: (M,) int material indices, each in [0, number of materials).
        texture_seed: Seed of the procedural textures.
        obstacle_radius: Capsule radius, m.
        obstacle_height: Capsule height, m.

    Raises:
        ValueError: A field has the wrong shape or a value outside its range; the message names it.
    """

    times: np.ndarray
    positions: np.ndarray
    quaternions: np.ndarray
    frame_rate: float
    obstacles: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    materials: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    texture_seed: int = 0
    obstacle_radius: float = 0.5
    obstacle_height: float = 2.0

    def __post_init__(self) -> None:
        self.times = np.asarray(self.times, np.float64)
        self.positions = np.asarray(self.positions, np.float64)
        self.quaternions = np.asarray(self.quaternions, np.float64)
        self.obstacles = np.asarray(self.obstacles, np.float64).reshape(-1, 2)
        self.materials = np.asarray(self.materials, np.int64).reshape(-1)
        count = len(self.times)
        if self.times.ndim != 1 or count < 2:
            raise ValueError(f"times must be a 1-D array of at least 2 frames, got shape {self.times.shape}")
        if not np.all(np.isfinite(self.times)) or np.any(np.diff(self.times) <= 0):
            raise ValueError("times must be finite and strictly increasing")
        if self.positions.shape != (count, 3) or not np.all(np.isfinite(self.positions)):
            raise ValueError(f"positions must be finite with shape ({count}, 3), got {self.positions.shape}")
        if self.quaternions.shape != (count, 4):
            raise ValueError(f"quaternions must have shape ({count}, 4), got {self.quaternions.shape}")
        norms = np.linalg.norm(self.quaternions, axis=1)
        if not np.all(np.abs(norms - 1.0) <= _QUAT_NORM_TOLERANCE):
            raise ValueError(
                f"quaternions must have unit norm (within {_QUAT_NORM_TOLERANCE}), got norms in "
                f"[{norms.min():.6g}, {norms.max():.6g}]"
            )
        if (
            isinstance(self.frame_rate, bool)
            or not np.isfinite(self.frame_rate)
            or not 0.0 < self.frame_rate <= 1000.0
        ):
            raise ValueError(f"frame_rate must be in (0, 1000] Hz, got {self.frame_rate!r}")
        self.frame_rate = float(self.frame_rate)
        if len(self.materials) != len(self.obstacles):
            raise ValueError(
                f"materials must have one entry per obstacle ({len(self.obstacles)}), got {len(self.materials)}"
            )
        if not 0.0 < self.obstacle_radius < self.obstacle_height / 2.0:
            raise ValueError(
                f"obstacle_radius must be in (0, obstacle_height / 2 = {self.obstacle_height / 2}), "
                f"got {self.obstacle_radius!r}"
            )
        self.texture_seed = int(self.texture_seed)
        self.obstacle_radius = float(self.obstacle_radius)
        self.obstacle_height = float(self.obstacle_height)

    def __len__(self) -> int:
        return len(self.times)

    def rotations(self) -> np.ndarray:
        """(N, 3, 3) world-from-camera rotation matrices (OpenCV axes)."""
        return matrix_from_quat(self.quaternions)

    def arc_length(self) -> np.ndarray:
        """(N,) cumulative distance travelled by the camera along the path, m (0 at the first frame)."""
        steps = np.linalg.norm(np.diff(self.positions, axis=0), axis=1)
        return np.concatenate([[0.0], np.cumsum(steps)])

    def with_poses(self, times: np.ndarray, positions: np.ndarray, quaternions: np.ndarray) -> CameraPath:
        """The same scene and frame rate with other poses."""
        return CameraPath(
            times=times,
            positions=positions,
            quaternions=quaternions,
            frame_rate=self.frame_rate,
            obstacles=self.obstacles.copy(),
            materials=self.materials.copy(),
            texture_seed=self.texture_seed,
            obstacle_radius=self.obstacle_radius,
            obstacle_height=self.obstacle_height,
        )


def path_from_poses(
    rotations: np.ndarray, positions: np.ndarray, frame_rate: float, **scene: Any
) -> CameraPath:
    """A :class:`CameraPath` from per-frame camera poses (a scripted path).

    Args:
        rotations: (N, 3, 3) world-from-camera rotations, OpenCV axes.
        positions: (N, 3) camera positions, m.
        frame_rate: Frames per second, in (0, 1000].
        **scene: Further :class:`CameraPath` fields (``obstacles``, ``materials``, ``texture_seed``, ...).

    Returns:
        The path, frame ``i`` at time ``i / frame_rate``.

    Raises:
        ValueError: As :class:`CameraPath`.
    """
    positions = np.asarray(positions, np.float64)
    if isinstance(frame_rate, bool) or not isinstance(frame_rate, (int, float)) or frame_rate <= 0:
        raise ValueError(f"frame_rate must be in (0, 1000] Hz, got {frame_rate!r}")
    times = np.arange(len(positions)) / float(frame_rate)
    return CameraPath(
        times, positions, quat_from_matrix(np.asarray(rotations)).reshape(-1, 4), frame_rate, **scene
    )


def resample_by_distance(
    path: CameraPath, distance_per_frame: float, max_frames: int | None = None
) -> CameraPath:
    """Resample a path to a fixed distance travelled per frame (the thesis's distance-per-frame variable).

    New frame ``k`` lies at arc length ``k · distance_per_frame`` along the recorded path: its position is
    interpolated linearly and its rotation by slerp between the two recorded frames around it. The frame rate
    is kept, so the frame times are ``k / frame_rate``: a larger distance per frame is a faster flight.

    Args:
        path: The recorded path; it must move (positive total length).
        distance_per_frame: Metres per frame, in (0, path length].
        max_frames: Most frames to keep (from the start), an integer >= 2, or None for the whole path.

    Returns:
        The resampled path (same scene).

    Raises:
        ValueError: ``distance_per_frame`` or ``max_frames`` out of range, or the path does not move.
    """
    arc = path.arc_length()
    length = float(arc[-1])
    if length <= 0.0:
        raise ValueError("cannot resample by distance a path that does not move (total length 0 m)")
    if (
        isinstance(distance_per_frame, bool)
        or not isinstance(distance_per_frame, (int, float, np.integer, np.floating))
        or not 0.0 < distance_per_frame <= length
    ):
        raise ValueError(
            f"distance_per_frame must be in (0, {length:.6g}] m (the path length), got {distance_per_frame!r}"
        )
    if max_frames is not None and (
        isinstance(max_frames, bool) or not isinstance(max_frames, (int, np.integer)) or max_frames < 2
    ):
        raise ValueError(f"max_frames must be an integer >= 2 or None, got {max_frames!r}")
    # The small slack keeps the end frame when the length is a whole number of steps up to rounding.
    count = math.floor(length / distance_per_frame + 1e-9) + 1
    if max_frames is not None:
        count = min(count, int(max_frames))
    targets = np.minimum(np.arange(count) * float(distance_per_frame), length)
    segment = np.clip(np.searchsorted(arc, targets, side="right") - 1, 0, len(arc) - 2)
    span = arc[segment + 1] - arc[segment]
    fraction = np.divide(targets - arc[segment], span, out=np.zeros_like(targets), where=span > 0.0).clip(
        0.0, 1.0
    )
    positions = path.positions[segment] + fraction[:, None] * (
        path.positions[segment + 1] - path.positions[segment]
    )
    quaternions = slerp(path.quaternions[segment], path.quaternions[segment + 1], fraction)
    times = np.arange(count) / path.frame_rate
    return path.with_poses(times, positions, quaternions)


def save_path(path: CameraPath, file: str | Path) -> Path:
    """Write a path to an NPZ file (format in the module docstring); returns the file's path."""
    file = Path(file)
    file.parent.mkdir(parents=True, exist_ok=True)
    with file.open("wb") as handle:
        np.savez(
            handle,
            format=np.array(FORMAT_NAME),
            version=np.array(FORMAT_VERSION, np.int64),
            times=path.times,
            positions=path.positions,
            quaternions=path.quaternions,
            frame_rate=np.array(path.frame_rate),
            obstacles=path.obstacles,
            materials=path.materials,
            texture_seed=np.array(path.texture_seed, np.int64),
            obstacle_radius=np.array(path.obstacle_radius),
            obstacle_height=np.array(path.obstacle_height),
        )
    return file


def load_path(file: str | Path) -> CameraPath:
    """Read a path written by :func:`save_path`.

    Raises:
        FileNotFoundError: The file does not exist.
        ValueError: Not a FlowNav camera-path file, an unsupported version, or invalid contents.
    """
    file = Path(file)
    if not file.is_file():
        raise FileNotFoundError(f"camera path file not found: {file}")
    with np.load(file, allow_pickle=False) as data:
        if "format" not in data or str(data["format"]) != FORMAT_NAME:
            raise ValueError(f"{file}: not a {FORMAT_NAME} file")
        version = int(data["version"])
        if version != FORMAT_VERSION:
            raise ValueError(f"{file}: unsupported version {version} (supported: {FORMAT_VERSION})")
        return CameraPath(
            times=data["times"],
            positions=data["positions"],
            quaternions=data["quaternions"],
            frame_rate=float(data["frame_rate"]),
            obstacles=data["obstacles"],
            materials=data["materials"],
            texture_seed=int(data["texture_seed"]),
            obstacle_radius=float(data["obstacle_radius"]),
            obstacle_height=float(data["obstacle_height"]),
        )


# --- recording a flight ---------------------------------------------------------------------------------------
def record_env_flight(
    env: Any,
    policy: Callable[[Any, int], np.ndarray],
    steps: int,
    seed: int | None = None,
    texture_seed: int = 0,
) -> CameraPath:
    """Fly :class:`flownav_env.FlowNavEnv` with ``policy`` and record the forward camera's path.

    Args:
        env: A FlowNavEnv (or a wrapper of one).
        policy: ``policy(observation, step) -> action``.
        steps: Most steps to fly, an integer >= 1; the recording stops early when the episode ends.
        seed: Seed of ``env.reset``.
        texture_seed: The env's ``texture_seed`` (the env does not keep it), stored with the path so that
            playback shows the same world.

    Returns:
        The camera path (reset frame plus one frame per step) with the episode's obstacles and materials.

    Raises:
        ValueError: ``steps`` is not a positive integer, or the episode ended before a second frame.
    """
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 1:
        raise ValueError(f"steps must be an integer >= 1, got {steps!r}")
    base = env.unwrapped
    observation, _ = env.reset(seed=seed)
    rotations, positions = [], []

    def record() -> None:
        rotation, position = base.physics.camera_pose()
        rotations.append(rotation)
        positions.append(position)

    record()
    for step in range(int(steps)):
        observation, _, terminated, truncated, _ = env.step(policy(observation, step))
        record()
        if terminated or truncated:
            break
    physics = base.physics
    obstacle_count = len(physics.obstacle_positions)
    geom_materials = physics.model.geom_matid[physics.obstacle_geoms[:obstacle_count]]
    materials = np.array(
        [int(np.flatnonzero(physics.material_ids == m)[0]) for m in geom_materials], np.int64
    )
    return path_from_poses(
        np.asarray(rotations),
        np.asarray(positions),
        base.frame_rate,
        obstacles=physics.obstacle_positions.copy(),
        materials=materials,
        texture_seed=int(texture_seed),
        obstacle_radius=base.layout_params.obstacle_radius,
        obstacle_height=base.layout_params.obstacle_height,
    )


# --- playback -------------------------------------------------------------------------------------------------
def _require_number(name: str, value: Any, low: float, high: float, low_open: bool = False) -> float:
    interval = f"{'(' if low_open else '['}{low}, {high}]"
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a number in {interval}, got {value!r}")
    number = float(value)
    if not math.isfinite(number) or number > high or (number <= low if low_open else number < low):
        raise ValueError(f"{name} must be in {interval}, got {value!r}")
    return number


@dataclass(frozen=True)
class PlaybackSettings:
    """The test variables of one playback (thesis §5.2, Appendices C–H).

    Attributes:
        brightness: Scene light level, 1 = daylight, in [0, 4].
        distance_per_frame: Resample the path to this many metres per frame, in (0, 10], or None to play the
            recorded frames as they are.
        attitude_jitter_deg: Camera attitude disturbance per frame, uniform ± this per axis, in [0, 10] degrees.
            The disturbance is real (the camera turns) and known (the estimator is told the true motion).
        rotation_error: Relative error of each rotation component told to the estimator, in [0, 1].
        translation_error: Relative error of each translation component told to the estimator, in [0, 1].
        max_frames: Most frames to play (from the start), an integer >= 2, or None for all.
        seed: Seed of the jitter and motion errors; the same seed gives the same playback.

    Raises:
        ValueError: A value is outside its range; the message names it, the value and the range.
    """

    brightness: float = 1.0
    distance_per_frame: float | None = None
    attitude_jitter_deg: float = 0.0
    rotation_error: float = 0.0
    translation_error: float = 0.0
    max_frames: int | None = None
    seed: int = 0

    def __post_init__(self) -> None:
        _require_number("brightness", self.brightness, 0.0, 4.0)
        if self.distance_per_frame is not None:
            _require_number("distance_per_frame", self.distance_per_frame, 0.0, 10.0, low_open=True)
        _require_number("attitude_jitter_deg", self.attitude_jitter_deg, 0.0, 10.0)
        _require_number("rotation_error", self.rotation_error, 0.0, 1.0)
        _require_number("translation_error", self.translation_error, 0.0, 1.0)
        if self.max_frames is not None and (
            isinstance(self.max_frames, bool) or not isinstance(self.max_frames, int) or self.max_frames < 2
        ):
            raise ValueError(f"max_frames must be an integer >= 2 or None, got {self.max_frames!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)):
            raise ValueError(f"seed must be an integer, got {self.seed!r}")


@dataclass
class PlaybackFrame:
    """One played-back frame.

    Attributes:
        index: Frame number from 0.
        image: RGB frame (H, W, 3) uint8.
        rotation: World-from-camera rotation (OpenCV axes) the frame was rendered from, jitter included.
        position: Camera position, m.
        true_motion: ``(R, t)`` from the previous frame's camera to this one (``X_this = R X_prev + t``);
            identity and zero on frame 0.
        told_motion: The motion told to the estimator: ``true_motion`` with the configured errors.
    """

    index: int
    image: np.ndarray
    rotation: np.ndarray
    position: np.ndarray
    true_motion: tuple[np.ndarray, np.ndarray]
    told_motion: tuple[np.ndarray, np.ndarray]


class PlaybackWorld:
    """The FlowNav scene with a kinematically placed camera: renders and ray-casts a path's frames.

    The drone body is placed so that its forward camera has the requested pose (nothing is simulated), which
    makes playback exact and independent of the controller.

    Args:
        path: Supplies the scene (obstacles, materials, texture seed, capsule size).
        width: Image width in pixels, an integer in [16, 1280].
        height: Image height in pixels, an integer in [16, 1280].
        fov_deg: Vertical field of view in degrees, in [10, 150].

    Raises:
        ValueError: A size or the field of view is out of range.
    """

    def __init__(self, path: CameraPath, width: int, height: int, fov_deg: float = 60.0) -> None:
        import mujoco

        from flownav_env.physics import FlowNavPhysics
        from flownav_env.quadrotor import ControllerGains, QuadrotorParams
        from flownav_env.rendering import CameraRenderer
        from flownav_env.scene import LayoutParams, material_names

        for name, value in (("width", width), ("height", height)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 16 <= value <= 1280:
                raise ValueError(f"{name} must be an integer in [16, 1280], got {value!r}")
        self.fov_deg = _require_number("fov_deg", fov_deg, 10.0, 150.0)
        materials = len(material_names())
        if len(path.materials) and (path.materials.min() < 0 or path.materials.max() >= materials):
            raise ValueError(f"materials must be in [0, {materials - 1}], got {path.materials.tolist()}")
        self._mujoco = mujoco
        self.width, self.height = int(width), int(height)
        self.layout = LayoutParams(
            obstacle_radius=path.obstacle_radius,
            obstacle_height=path.obstacle_height,
            max_obstacles=max(1, len(path.obstacles)),
        )
        self.physics = FlowNavPhysics(
            self.layout,
            QuadrotorParams(),
            ControllerGains(),
            timestep=0.004,
            camera_fov_deg=self.fov_deg,
            offscreen_size=(self.width, self.height),
            texture_seed=path.texture_seed,
        )
        self.physics.place_obstacles(path.obstacles, path.materials)
        self.physics.reset_drone(np.array([0.0, 0.0, 1.0]), 0.0, np.zeros(3))
        self.obstacles = path.obstacles.copy()
        self.renderer = CameraRenderer(self.physics.model, self.width, self.height)
        model, camera = self.physics.model, self.physics.camera_id
        mount = np.empty(9)
        mujoco.mju_quat2Mat(mount, model.cam_quat[camera])
        self._mount_rotation = mount.reshape(3, 3)
        self._mount_offset = model.cam_pos[camera].copy()

    def set_camera_pose(self, rotation: np.ndarray, position: np.ndarray) -> None:
        """Place the drone so that its camera has this world pose (OpenCV axes) and refresh the kinematics."""
        mujoco, physics = self._mujoco, self.physics
        camera_mujoco = np.asarray(rotation, np.float64) @ MUJOCO_FROM_OPENCV
        body_rotation = camera_mujoco @ self._mount_rotation.T
        body_position = np.asarray(position, np.float64) - body_rotation @ self._mount_offset
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, np.ascontiguousarray(body_rotation).reshape(9))
        physics.data.qpos[:3] = body_position
        physics.data.qpos[3:7] = quat
        physics.data.qvel[:] = 0.0
        mujoco.mj_kinematics(physics.model, physics.data)
        mujoco.mj_camlight(physics.model, physics.data)

    def camera_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """The camera's current world pose as MuJoCo computed it: (R world-from-camera, OpenCV axes; p)."""
        return self.physics.camera_pose()

    def set_brightness(self, brightness: float) -> None:
        """Scene light level (1 = daylight)."""
        self.physics.set_brightness(_require_number("brightness", brightness, 0.0, 4.0))

    def render(self) -> np.ndarray:
        """RGB frame (H, W, 3) uint8 from the current camera pose."""
        return self.renderer.render(self.physics.data, self.physics.camera_id)

    def true_depth(self, rays: np.ndarray, rotation: np.ndarray, position: np.ndarray) -> np.ndarray:
        """Exact z-depth along camera rays ``[x, y, 1]`` (N, 3) from a camera pose; NaN where nothing is hit."""
        return self.physics.ray_depths(np.asarray(rays, np.float64).reshape(-1, 3), rotation, position)

    def label_points(self, world_points: np.ndarray) -> np.ndarray:
        """Which surface each world point lies on: capsule index (>= 0), -1 ground, -2 nothing (NaN point)."""
        return label_world_points(
            world_points, self.obstacles, self.layout.obstacle_radius, self.layout.obstacle_height
        )

    def close(self) -> None:
        """Release the GL context."""
        self.renderer.close()


def label_world_points(
    world_points: np.ndarray, obstacles: np.ndarray, radius: float, height: float, tolerance: float = 0.02
) -> np.ndarray:
    """Label 3-D points by the surface they lie on: capsule index, -1 for the ground, -2 for NaN (sky).

    Args:
        world_points: (N, 3) points in the world, m (NaN rows for rays that hit nothing).
        obstacles: (M, 2) capsule centres (x, y), m; capsules stand on the ground.
        radius: Capsule radius, m.
        height: Capsule height, m.
        tolerance: Slack in metres on the capsule radius (ray-cast hits carry float rounding).

    Returns:
        (N,) int64 labels.
    """
    points = np.asarray(world_points, np.float64).reshape(-1, 3)
    labels = np.full(len(points), -1, np.int64)
    labels[~np.all(np.isfinite(points), axis=1)] = -2
    if len(obstacles):
        # Distance from each point to each capsule's axis segment (z from radius to height - radius).
        axis_z = np.clip(points[:, 2:3], radius, height - radius)
        horizontal = np.linalg.norm(points[:, None, :2] - np.asarray(obstacles)[None, :, :], axis=2)
        distance = np.hypot(horizontal, points[:, 2:3] - axis_z)
        nearest = np.argmin(distance, axis=1)
        on_capsule = np.take_along_axis(distance, nearest[:, None], axis=1)[:, 0] <= radius + tolerance
        on_capsule &= labels != -2
        labels[on_capsule] = nearest[on_capsule]
    return labels


def play_back(path: CameraPath, world: PlaybackWorld, settings: PlaybackSettings) -> Iterator[PlaybackFrame]:
    """Render a recorded path under the settings' test variables, frame by frame.

    Order per frame (as in :class:`flownav_env.FlowNavEnv`): draw the attitude jitter, place the camera at the
    recorded pose turned by the jitter (about its own centre), render, then build the true relative motion
    from the previous rendered pose and corrupt it into the told motion. All random numbers come from one
    generator seeded with ``settings.seed``, so a playback is deterministic for a seed.

    Args:
        path: The recorded path.
        world: The scene to render in (built from the same path).
        settings: The test variables.

    Yields:
        One :class:`PlaybackFrame` per (resampled) frame.

    Raises:
        ValueError: ``distance_per_frame`` is longer than the path.
    """
    if settings.distance_per_frame is not None:
        path = resample_by_distance(path, settings.distance_per_frame, settings.max_frames)
    elif settings.max_frames is not None and settings.max_frames < len(path):
        count = settings.max_frames
        path = path.with_poses(path.times[:count], path.positions[:count], path.quaternions[:count])
    rng = np.random.default_rng(settings.seed)
    world.set_brightness(settings.brightness)
    previous: tuple[np.ndarray, np.ndarray] | None = None
    for index, (rotation, position) in enumerate(zip(path.rotations(), path.positions, strict=True)):
        disturbed = rotation @ jitter_rotation(settings.attitude_jitter_deg, rng)
        world.set_camera_pose(disturbed, position)
        pose = world.camera_pose()
        image = world.render()
        if previous is None:
            true_motion = (np.eye(3), np.zeros(3))
            told_motion = true_motion
        else:
            true_motion = relative_motion(*previous, *pose)
            told_motion = corrupt_motion(
                *true_motion, settings.rotation_error, settings.translation_error, rng
            )
        previous = pose
        yield PlaybackFrame(index, image, pose[0], pose[1], true_motion, told_motion)
