"""A scripted flight rendered by FlowNav, with the true motion of every frame pair: what both speed benchmarks
time the estimator and the env on; and the bare FAST + LK work both time them against."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import cv2
import numpy as np

from agents.analysis.perf_rows import FlightDescription
from estimator import CameraIntrinsics
from flownav_env import FlowNavEnv


@dataclass
class Flight:
    """A rendered flight: grayscale frames, the true motion of each pair and a ground-truth depth oracle.

    Attributes:
        frames: N + 1 uint8 (H, W) grayscale frames.
        rotations: N rotations, ``X_{k+1} = R_k @ X_k + t_k`` in OpenCV camera axes.
        translations: N translations in metres.
        intrinsics: the camera's :class:`estimator.CameraIntrinsics`.
        true_depth: ``true_depth(k, pixels)``: ray-cast z-depth (m) at pixels of frame k; NaN on a miss.
        description: how the flight was made, for the report.
    """

    frames: list[np.ndarray]
    rotations: list[np.ndarray]
    translations: list[np.ndarray]
    intrinsics: CameraIntrinsics
    true_depth: Callable[[int, np.ndarray], np.ndarray]
    description: FlightDescription


def scripted_action(step: int) -> np.ndarray:
    """The flight's action at ``step``: gentle weaving in yaw, height and sideways, so the camera rotates.

    Rotation between frames is what the derotation has to remove; a straight flight would leave it idle.
    """
    # Yaw rate as a cosine makes the heading a sine, centred on the course axis, so the flight does not drift
    # sideways into a capsule; with layout "three" and seed 0 it stays clear for 80 frames (0.37 m clearance).
    return np.array(
        [
            0.2 * math.sin(2 * math.pi * step / 40),
            0.3 * math.sin(2 * math.pi * step / 25),
            0.4 * math.cos(2 * math.pi * step / 30),
        ]
    )


def fast_lk(
    detector: cv2.FastFeatureDetector,
    previous: np.ndarray,
    current: np.ndarray,
    win_size: int,
    max_level: int,
    max_points: int | None = None,
) -> int:
    """The least any FAST + LK pipeline does on a frame pair: FAST corners on ``previous`` (the first
    ``max_points``) tracked into ``current`` by one pyramidal LK call. Returns the number of corners found."""
    keypoints = detector.detect(previous)
    if keypoints:
        points = np.asarray(cv2.KeyPoint.convert(keypoints))[:max_points].reshape(-1, 1, 2)
        cv2.calcOpticalFlowPyrLK(
            previous, current, points, None, winSize=(win_size, win_size), maxLevel=max_level
        )
    return len(keypoints)


@contextmanager
def record_flight(
    frames: int, width: int = 640, height: int = 480, layout: str = "three", seed: int = 0
) -> Iterator[Flight]:
    """Fly the scripted flight in FlowNavEnv and yield its frames and true motions.

    The env stays open while the context is active because the ground-truth depth oracle ray-casts in its
    scene.

    Args:
        frames: number of frame pairs (N); N + 1 frames are rendered.
        width, height: camera resolution in pixels.
        layout: FlowNavEnv layout.
        seed: ``reset`` seed (obstacle jitter).

    Yields:
        The :class:`Flight`.

    Raises:
        ValueError: ``frames`` < 1, or the flight ended (collision, goal) before N pairs were recorded.
    """
    if isinstance(frames, bool) or not isinstance(frames, int) or frames < 1:
        raise ValueError(f"frames must be an integer >= 1, got {frames!r}")
    env = FlowNavEnv(layout=layout, camera_width=width, camera_height=height)
    try:
        env.reset(seed=seed)
        physics = env.physics
        gray = [_gray(env)]
        poses = [physics.camera_pose()]
        rotations, translations = [], []
        for step in range(frames):
            _, _, terminated, _, info = env.step(scripted_action(step))
            if terminated:
                raise ValueError(
                    f"the scripted flight ended after {step + 1} of frames={frames} steps "
                    f"(collision={info['collision']}, success={info['success']}); use fewer frames"
                )
            gray.append(_gray(env))
            poses.append(physics.camera_pose())
            rotations.append(np.asarray(info["true_rotation"], np.float64))
            translations.append(np.asarray(info["true_translation"], np.float64))

        intrinsics = env.intrinsics

        def true_depth(index: int, pixels: np.ndarray) -> np.ndarray:
            if len(pixels) == 0:
                return np.zeros(0)
            rays = intrinsics.rays(pixels)
            return physics.ray_depths(rays, *poses[index])

        yield Flight(
            frames=gray,
            rotations=rotations,
            translations=translations,
            intrinsics=intrinsics,
            true_depth=true_depth,
            description=FlightDescription(
                layout=layout,
                seed=seed,
                frames=frames,
                width=width,
                height=height,
                fov_deg=env.physics.model.cam_fovy[physics.camera_id],
                frame_rate=env.frame_rate,
                forward_speed=env.forward_speed,
            ),
        )
    finally:
        env.close()


def _gray(env: FlowNavEnv) -> np.ndarray:
    """The env's last camera frame in grayscale."""
    frame = env.last_frame
    if frame is None:
        raise RuntimeError("the env has rendered no frame: reset it first")
    return cv2.cvtColor(frame, cv2.COLOR_RGB2GRAY)
