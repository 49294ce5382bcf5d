"""Playing a camera path back under changed test variables (the thesis's playback mode, §3.5, §5.2)."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import cv2
import numpy as np

from flownav_env.playback.path import CameraPath, resample_by_distance
from flownav_env.playback.world import PlaybackWorld
from flownav_env.sensor import SensorPipeline
from flownav_env.setting_rules import Range
from flownav_env.settings import DEPTH_ERROR_FIELDS, SENSOR_FIELDS, SensorSettings
from flownav_env.settings_check import check_setting

# Metres per frame (distance travelled per frame) a path may be resampled to.
DISTANCE_PER_FRAME = Range(0.0, 10.0, low_open=True, unit="m")


@dataclass(frozen=True)
class PlaybackSettings(SensorSettings):
    """The test variables of one playback (thesis §5.2, Appendices C–H): the env's sensor settings, declared once
    in :class:`~flownav_env.settings.SensorSettings` with their ranges and meanings, plus what only playback has.

    The sensor settings act as in the env, with two differences: ``attitude_jitter_deg`` is real (the camera
    turns) and known (the estimator is told the true motion), and the told motion's drift steps every
    1/``frame_rate`` of the played path. ``depth_noise``, ``depth_outliers`` and ``depth_dropout`` are refused
    unless 0: playback runs no estimator (its callers do), so it has no depths to corrupt; apply
    :func:`flownav_env.sensor_errors.corrupt_depths` to the estimates, or fly the env.

    Attributes:
        distance_per_frame: Resample the path to this many metres per frame (:data:`DISTANCE_PER_FRAME`), or
            None to play the recorded frames as they are.
        max_frames: Most frames to play (from the start), an integer >= 2, or None for all.
        seed: Seed of the jitter and motion errors; the same seed gives the same playback.

    Raises:
        ValueError: A value is outside its range; the message names it, the value and the range.
    """

    distance_per_frame: float | None = None
    max_frames: int | None = None
    seed: int = 0

    def __post_init__(self) -> None:
        if self.distance_per_frame is not None:
            DISTANCE_PER_FRAME.check("distance_per_frame", self.distance_per_frame)
        for name in SENSOR_FIELDS:
            check_setting(name, getattr(self, name))
        for name in DEPTH_ERROR_FIELDS:
            if getattr(self, name) != 0:
                raise ValueError(
                    f"{name} must be 0 in playback, got {getattr(self, name)!r}: playback runs no estimator, "
                    "so it has no depths to corrupt (apply flownav_env.sensor_errors.corrupt_depths to the "
                    "estimates, or fly the env)"
                )
        if self.max_frames is not None and (
            isinstance(self.max_frames, bool) or not isinstance(self.max_frames, int) or self.max_frames < 2
        ):
            raise ValueError(f"max_frames must be an integer >= 2 or None, got {self.max_frames!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)):
            raise ValueError(f"seed must be an integer, got {self.seed!r}")

    @property
    def sensor(self) -> SensorSettings:
        """The sensor variables of this playback."""
        return SensorSettings(**{name: getattr(self, name) for name in SENSOR_FIELDS})


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
        gray: The frame in grey levels (H, W) uint8, as the estimators read it.
    """

    index: int
    image: np.ndarray
    rotation: np.ndarray
    position: np.ndarray
    true_motion: tuple[np.ndarray, np.ndarray]
    told_motion: tuple[np.ndarray, np.ndarray]
    gray: np.ndarray


def play_back(path: CameraPath, world: PlaybackWorld, settings: PlaybackSettings) -> Iterator[PlaybackFrame]:
    """Render a recorded path under the settings' test variables, frame by frame.

    Each frame goes through :class:`flownav_env.sensor.SensorPipeline`, the env's own per-frame order; the
    camera is placed at the recorded pose turned by the jitter (about its own centre). All random numbers come
    from one generator seeded with ``settings.seed``, so a playback is deterministic for a seed.

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
    sensor, pipeline = settings.sensor, SensorPipeline(path.frame_rate)
    for index, (rotation, position) in enumerate(zip(path.rotations(), path.positions, strict=True)):
        # The camera at the recorded pose, turned by the jitter about its own centre.
        world.set_camera_pose(rotation @ pipeline.jitter(sensor, rng), position)
        image = world.render()
        pose = world.camera_pose()
        motion = pipeline.start(pose) if index == 0 else pipeline.motion(sensor, rng, pose)
        gray = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
        yield PlaybackFrame(index, image, *motion.pose, motion.true_motion, motion.told_motion, gray)
