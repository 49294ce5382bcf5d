"""Camera paths: the thesis's recorded flights (§3.4), their file format and their resampling.

A :class:`CameraPath` is a sequence of camera poses plus the frame rate and the scene it was recorded in. It
comes from a scripted path (:func:`path_from_poses`) or from a flight of the Gymnasium env
(:func:`flownav_env.playback.record_env_flight`), is saved to and loaded from an NPZ file (:func:`save_path`,
:func:`load_path`), and can be resampled to a fixed distance per frame (:func:`resample_by_distance`, slerp
for the rotations, as the thesis did) before :func:`flownav_env.playback.play_back` renders it.

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

Plain numpy: nothing here touches MuJoCo.
"""

from __future__ import annotations

import math
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypedDict, Unpack

import numpy as np

from flownav_env.rotations import matrix_from_quat, quat_from_matrix, slerp

FORMAT_NAME = "flownav-camera-path"
FORMAT_VERSION = 1
_PATH_KEYS = (
    "times",
    "positions",
    "quaternions",
    "frame_rate",
    "obstacles",
    "materials",
    "texture_seed",
    "obstacle_radius",
    "obstacle_height",
)
_QUAT_NORM_TOLERANCE = 1e-6


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
        if not np.all(np.isfinite(self.obstacles)):
            raise ValueError("obstacles must be finite (x, y) positions in metres, got NaN or infinity")
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


class SceneFields(TypedDict, total=False):
    """The :class:`CameraPath` fields that describe the scene rather than the camera's motion."""

    obstacles: np.ndarray
    materials: np.ndarray
    texture_seed: int
    obstacle_radius: float
    obstacle_height: float


def path_from_poses(
    rotations: np.ndarray, positions: np.ndarray, frame_rate: float, **scene: Unpack[SceneFields]
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
    try:
        with np.load(file, allow_pickle=False) as data:
            if "format" not in data or str(data["format"]) != FORMAT_NAME:
                raise ValueError(f"{file}: not a {FORMAT_NAME} file")
            version = int(data["version"])
            if version != FORMAT_VERSION:
                raise ValueError(f"{file}: unsupported version {version} (supported: {FORMAT_VERSION})")
            missing = [key for key in _PATH_KEYS if key not in data]
            if missing:
                raise ValueError(
                    f"{file}: missing arrays {missing} (a {FORMAT_NAME} file holds {list(_PATH_KEYS)})"
                )
            arrays = {key: data[key] for key in _PATH_KEYS}
    except (OSError, EOFError, zipfile.BadZipFile) as error:
        # A truncated or foreign file: np.load's own errors name neither the file nor the format.
        raise ValueError(
            f"{file}: not a readable {FORMAT_NAME} file ({type(error).__name__}: {error})"
        ) from error
    try:
        return CameraPath(
            times=arrays["times"],
            positions=arrays["positions"],
            quaternions=arrays["quaternions"],
            frame_rate=float(arrays["frame_rate"]),
            obstacles=arrays["obstacles"],
            materials=arrays["materials"],
            texture_seed=int(arrays["texture_seed"]),
            obstacle_radius=float(arrays["obstacle_radius"]),
            obstacle_height=float(arrays["obstacle_height"]),
        )
    except ValueError as error:
        raise ValueError(f"{file}: {error}") from error
