"""Pure kernels of the thesis experiments: depth from one flow component, per-frame depth metrics and the
rotation residuals of Table 2."""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import TypedDict

import numpy as np

from estimator import CameraIntrinsics
from estimator.accuracy import relative_depth_error
from estimator.geometry import derotate, euler_zyx_to_rotation, rotation_to_euler_zyx

METHODS = ("thesis", "triangulation")
COMPONENT_VARIANTS = ("x-flow", "y-flow")
# A depth counts as accurate within this relative error (the share of depths within 10 %).
WITHIN = 0.10


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


class FrameRow(TypedDict):
    """One estimated frame of a method in a playback: its points (N, 2), their depths, validity, true depths
    and labels (the capsule each ray hits, -1 for none), all (N,), and the number of points tracked."""

    points: np.ndarray
    depth: np.ndarray
    valid: np.ndarray
    true_depth: np.ndarray
    labels: np.ndarray
    tracked: int


class DepthMetrics(TypedDict):
    """A method's error statistics over a run (:func:`depth_metrics`)."""

    median_rel_error: float
    within_10pct: float
    valid_per_frame: float
    tracked_per_frame: float
    evaluated: int
    frames: int


class MetricRow(DepthMetrics):
    """A run's row of a method's statistics (:func:`metric_rows`), with the capsule-only error and count."""

    run: str
    method: str
    obstacle_median_rel_error: float
    obstacle_valid_per_frame: float


def depth_metrics(frames: list[FrameRow], obstacles_only: bool = False) -> DepthMetrics:
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
        relative = relative_depth_error(frame["depth"][valid], frame["true_depth"][valid])
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


def metric_rows(run: str, methods: Mapping[str, list[FrameRow]], names: Iterable[str]) -> list[MetricRow]:
    """One row of :func:`depth_metrics` per method named in ``names``, from a playback's per-method frames
    (``RunResult.methods``), with the capsule-only error and count beside it."""
    rows = []
    for name in names:
        frames = methods[name]
        obstacle = depth_metrics(frames, obstacles_only=True)
        row: MetricRow = {
            "run": run,
            "method": name,
            **depth_metrics(frames),
            "obstacle_median_rel_error": obstacle["median_rel_error"],
            "obstacle_valid_per_frame": obstacle["valid_per_frame"],
        }
        rows.append(row)
    return rows


def rotation_residuals(
    points: np.ndarray,
    next_points: np.ndarray,
    rotation: np.ndarray,
    intrinsics: CameraIntrinsics,
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
    if thesis_derotation:
        rotation = euler_zyx_to_rotation(*rotation_to_euler_zyx(rotation))
    derotated, _ = derotate(intrinsics.normalize(points), rotation)
    predicted = intrinsics.denormalize(derotated)
    next_points = np.asarray(next_points, np.float64)
    compensated = np.linalg.norm(next_points - predicted, axis=1)
    uncompensated = np.linalg.norm(next_points - np.asarray(points, np.float64), axis=1)
    return compensated, uncompensated
