"""One playback of a camera path through every estimator variant, with ground truth by ray casting."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from tqdm import tqdm

from agents.studies.thesis.attitude import AttitudeRotationError
from agents.studies.thesis.metrics import COMPONENT_VARIANTS, METHODS, FrameRow, component_depth
from estimator import CameraIntrinsics, DepthPoints, FlowDepthEstimator
from estimator.geometry import solve_depth, valid_depth_mask
from flownav_env.playback import (
    CameraPath,
    PlaybackFrame,
    PlaybackSettings,
    PlaybackWorld,
    play_back,
    resample_by_distance,
)


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
        residuals: Per frame the tracked points' p1, p2 and tracked mask (thesis estimator), the told and true
            rotations and the camera's world-from-camera rotation (its attitude) when it was rendered.
    """

    methods: dict[str, list[FrameRow]] = field(default_factory=dict)
    references: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    timings: dict[str, dict[str, list[float]]] = field(default_factory=dict)
    render_s: list[float] = field(default_factory=list)
    residuals: list[dict[str, np.ndarray]] = field(default_factory=list)


def _reference_depths(
    world: PlaybackWorld, intrinsics: CameraIntrinsics, rotation: np.ndarray, position: np.ndarray
) -> np.ndarray:
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
    path: CameraPath,
    world: PlaybackWorld,
    settings: PlaybackSettings,
    estimator_kwargs: dict[str, Any],
    *,
    component_variants: bool = False,
    keep_residuals: bool = False,
    attitude_error: float = 0.0,
    progress: bool = True,
    description: str = "",
) -> RunResult:
    """Play a path back through the renderer into both estimators and compare every depth with the truth.

    Args:
        path: :class:`flownav_env.playback.CameraPath`.
        world: :class:`flownav_env.playback.PlaybackWorld` built from the path.
        settings: :class:`flownav_env.playback.PlaybackSettings`.
        estimator_kwargs: :class:`estimator.FlowDepthEstimator` kwargs (without ``method``).
        component_variants: Also compute x-flow-only and y-flow-only depths from the thesis estimator's tracks.
        keep_residuals: Keep p1, p2, the told and true rotations and the attitude per frame.
        attitude_error: Tell rotations built from absolute attitudes whose Euler angles each carry up to this
            relative error (:class:`agents.studies.thesis.attitude.AttitudeRotationError`), in place of the told
            rotation of ``settings``; its draws come from their own generator seeded with ``settings.seed``.
        progress: Show a tqdm progress bar.
        description: Label of the progress bar.

    Returns:
        A :class:`RunResult`.
    """
    intrinsics = CameraIntrinsics.from_fov(world.width, world.height, world.fov_deg)
    estimators = {m: FlowDepthEstimator(intrinsics, method=m, **estimator_kwargs) for m in METHODS}
    names = list(METHODS) + (list(COMPONENT_VARIANTS) if component_variants else [])
    result = RunResult(methods={name: [] for name in names}, timings={m: {} for m in METHODS})
    references = []
    previous_pose = None
    frames = play_back(path, world, settings)
    attitude = AttitudeRotationError(attitude_error, np.random.default_rng([settings.seed, 1]))
    bar = tqdm(total=_frame_count(path, settings), desc=description, disable=not progress, leave=False)
    while True:
        # Timed by hand around next(): the generator places the camera and renders inside it.
        start = time.perf_counter()
        frame = next(frames, None)
        if frame is None:
            break
        result.render_s.append(time.perf_counter() - start)
        bar.update()
        told_rotation, told_translation = frame.told_motion
        if attitude_error > 0:
            told_rotation = attitude.told_rotation(frame.rotation, first=frame.index == 0)
        outputs = {m: estimators[m].update(frame.image, told_rotation, told_translation) for m in METHODS}
        if previous_pose is None:
            previous_pose = (frame.rotation, frame.position)
            continue
        references.append(_reference_depths(world, intrinsics, *previous_pose))
        truth = _GroundTruth(world, intrinsics, *previous_pose)
        for method, points in outputs.items():
            result.methods[method].append(_frame_row(points, points.depth, points.valid, truth))
            for stage, seconds in points.timings.items():
                result.timings[method].setdefault(stage, []).append(seconds)
        thesis_points = outputs["thesis"]
        if component_variants:
            told = (told_rotation, told_translation)
            for name, (depth, valid) in _component_depths(
                thesis_points, told, intrinsics, estimators["thesis"]
            ):
                result.methods[name].append(_frame_row(thesis_points, depth, valid, truth))
        if keep_residuals:
            result.residuals.append(_residuals(thesis_points, told_rotation, frame))
        previous_pose = (frame.rotation, frame.position)
    bar.close()
    result.references = np.asarray(references).reshape(len(references), len(world.obstacles))
    return result


def _residuals(
    thesis_points: DepthPoints, told_rotation: np.ndarray, frame: PlaybackFrame
) -> dict[str, np.ndarray]:
    """What the rotation-residual analysis keeps of a frame: the thesis estimator's tracks, the told and true
    rotations, and the camera's attitude."""
    return {
        "points": thesis_points.points,
        "next_points": thesis_points.next_points,
        "tracked": thesis_points.tracked,
        "rotation": told_rotation,
        "true_rotation": frame.true_motion[0],
        "attitude": frame.rotation,
    }


def _frame_count(path: CameraPath, settings: PlaybackSettings) -> int:
    """How many frames :func:`play_back` renders, for the progress bar."""
    if settings.distance_per_frame is not None:
        return len(resample_by_distance(path, settings.distance_per_frame, settings.max_frames))
    return min(len(path), settings.max_frames or len(path))


class _GroundTruth:
    """True depth and the capsule hit (label) of points seen from one camera pose, by ray casting; each set of
    points is cast once, as both estimators and the component variants often ask for the same points."""

    def __init__(
        self, world: PlaybackWorld, intrinsics: CameraIntrinsics, rotation: np.ndarray, position: np.ndarray
    ) -> None:
        self.world, self.intrinsics, self.rotation, self.position = world, intrinsics, rotation, position
        self.cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

    def __call__(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        key = points.tobytes()
        if key not in self.cache:
            rays = self.intrinsics.rays(points)
            depth = self.world.true_depth(rays, self.rotation, self.position)
            hits = self.position + (rays * depth[:, None]) @ self.rotation.T
            self.cache[key] = (depth, self.world.label_points(hits))
        return self.cache[key]


def _frame_row(points: DepthPoints, depth: np.ndarray, valid: np.ndarray, truth: _GroundTruth) -> FrameRow:
    """One frame of a method: its points, their depths and validity, and the truth at those points."""
    true_depth, labels = truth(points.points)
    return {
        "points": points.points,
        "depth": depth,
        "valid": valid,
        "true_depth": true_depth,
        "labels": labels,
        "tracked": points.num_tracked,
    }


def _component_depths(
    thesis_points: DepthPoints,
    told: tuple[np.ndarray, np.ndarray],
    intrinsics: CameraIntrinsics,
    reference: FlowDepthEstimator,
) -> list[tuple[str, tuple[np.ndarray, np.ndarray]]]:
    """Per component variant, the depths of the thesis estimator's tracks from that flow component alone and
    where they are valid, under the thesis estimator's own parallax and epipolar limits."""
    told_rotation, told_translation = told
    normalized_prev = intrinsics.normalize(thesis_points.points)
    normalized_next = intrinsics.normalize(thesis_points.next_points)
    # The epipolar check of the full solution guards the single-component depths against mistracks.
    full = solve_depth(
        normalized_prev, normalized_next, told_rotation, told_translation, intrinsics.focal_scale
    )
    epipolar_ok = valid_depth_mask(full, 0.0, reference.max_epipolar_error_px)
    variants = []
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
        variants.append((name, (depth, valid)))
    return variants
