"""Evaluation of the estimator against ground truth on ICL-NUIM-style RGB-D sequences.

Sequence layout (as in the ICL-NUIM data shipped with Open3D's test data):

* ``color/``: frames as ``*.jpg`` or ``*.png``, sorted by name;
* ``depth/``: one uint16 PNG per frame, z-depth in millimetres (metres = value / 1000), 0 = unknown;
* ``trajectory.log``: per frame a header line ``i i i+1`` and four lines of the 4×4 camera-to-world pose
  ``P_i``. The motion from frame i to frame j is ``T = inv(P_j) @ P_i``: ``X_j = R X_i + t`` with
  ``R = T[:3, :3]``, ``t = T[:3, 3]``.

:func:`evaluate_sequence` runs the estimator on every pair (i, j) with ``0 < j - i <= max_gap`` using the
ground-truth motion and compares with the ground-truth depth of frame i; ``flownav eval-estimator`` prints
:func:`format_error_table` of the rows.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, TypedDict

import cv2
import numpy as np

from estimator.camera import CameraIntrinsics
from estimator.estimator import FlowDepthEstimator
from estimator.geometry import predict_next_pixels
from estimator.points import DepthPoints

_COLOR_SUFFIXES = (".jpg", ".jpeg", ".png")
_MILLIMETRES_PER_METRE = 1000.0
# The headline accuracy figure: share of valid points whose depth is within this relative error.
_WITHIN_FRACTION = 0.10
#: A depth is an outlier when it is off by more than half its true value: it then lands a histogram bin or more
#: from the truth at any distance, where smaller errors mostly blur within a bin.
OUTLIER_RELATIVE_ERROR = 0.5


class PairErrors(TypedDict):
    """One pair's row of :func:`evaluate_sequence` (see its Returns)."""

    pair: tuple[int, int]
    points: int
    tracked: int
    valid: int
    evaluated: int
    median_rel_error: float
    within_10pct: float
    median_epe_px: float
    time_ms: float


class StreamPairErrors(PairErrors):
    """One streamed pair's row of :func:`evaluate_stream`: :class:`PairErrors` and the mean baseline."""

    baseline_frames: float


#: Columns of :func:`format_error_table`: (row key, header, format).
TABLE_COLUMNS: tuple[tuple[str, str, str], ...] = (
    ("pair", "pair", "{0[0]}->{0[1]}"),
    ("tracked", "tracked", "{:d}"),
    ("valid", "valid", "{:d}"),
    ("median_rel_error", "median rel err", "{:.2%}"),
    ("within_10pct", "within 10%", "{:.1%}"),
    ("median_epe_px", "median EPE px", "{:.3f}"),
    ("time_ms", "time ms", "{:.1f}"),
)


def read_trajectory_log(path: Path) -> list[np.ndarray]:
    """Read the camera-to-world poses of a ``trajectory.log``.

    Args:
        path: The log file.

    Returns:
        One float64 (4, 4) pose per frame, in file order.

    Raises:
        FileNotFoundError: ``path`` does not exist.
        ValueError: The file is not blocks of a 3-number header and four 4-number rows.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"trajectory log not found: {path}")
    lines = [line.split() for line in path.read_text().splitlines() if line.strip()]
    if len(lines) % 5 != 0:
        raise ValueError(f"{path}: expected blocks of 5 lines (header + 4x4 pose), got {len(lines)} lines")
    poses = []
    for block in range(len(lines) // 5):
        rows = lines[5 * block + 1 : 5 * block + 5]
        try:
            pose = np.array([[float(value) for value in row] for row in rows], dtype=np.float64)
        except ValueError as error:
            raise ValueError(f"{path}: pose {block} is not numeric: {error}") from None
        if pose.shape != (4, 4):
            lengths = [len(row) for row in rows]
            raise ValueError(f"{path}: pose {block} must be 4x4, got rows of lengths {lengths}")
        poses.append(pose)
    return poses


def relative_depth_error(depth: np.ndarray, true_depth: np.ndarray) -> np.ndarray:
    """Element-wise ``|depth - true_depth| / true_depth``: the depth error as a share of the true distance.

    Relative, not absolute, because the estimator's error grows with distance and the thesis reports it so.
    Where there is nothing to compare (a true depth that is missing, i.e. NaN, or not positive, or an estimate
    that is not finite) the error is NaN, so a caller can pass every point and take ``nanmedian``.

    Args:
        depth: Estimated depths, any shape.
        true_depth: True depths, the same shape.

    Returns:
        The relative errors, the shape of the inputs, in the inputs' float type.
    """
    depth, true_depth = np.asarray(depth), np.asarray(true_depth)
    errors = np.full(np.shape(depth), np.nan, np.result_type(depth, true_depth, np.float32))
    usable = np.isfinite(true_depth) & (true_depth > 0) & np.isfinite(depth)
    errors[usable] = np.abs(depth[usable] - true_depth[usable]) / true_depth[usable]
    return errors


def relative_motion(pose_from: np.ndarray, pose_to: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Motion ``(R, t)`` with ``X_to = R X_from + t`` from two camera-to-world poses."""
    transform = np.linalg.inv(pose_to) @ pose_from
    rotation = transform[:3, :3]
    # Re-orthonormalise: the logged poses carry ~1e-16 rounding, and products of them a little more.
    u, _, vt = np.linalg.svd(rotation)
    return u @ vt, transform[:3, 3].copy()


def evaluate_sequence(
    sequence_dir: Path,
    intrinsics: CameraIntrinsics,
    method: str = "triangulation",
    max_gap: int = 4,
    # Passed straight on: FlowDepthEstimator checks each name and value.
    **estimator_params: Any,
) -> list[PairErrors]:
    """Run the estimator on every frame pair of a sequence and measure it against the ground truth.

    Args:
        sequence_dir: Folder with ``color/``, ``depth/`` and ``trajectory.log`` (see the module docstring).
        intrinsics: Camera intrinsics of the sequence.
        method: Depth method, ``"triangulation"`` or ``"thesis"``.
        max_gap: Largest frame gap ``j - i`` of an evaluated pair, an integer >= 1.
        **estimator_params: Further :class:`~estimator.FlowDepthEstimator` keyword arguments.

    Returns:
        One dict per pair (i, j), in order of i then j, with keys ``pair`` ``(i, j)``; ``points`` (keypoints
        detected); ``tracked``; ``valid``; ``evaluated`` (valid points with ground-truth depth);
        ``median_rel_error`` (median of ``|d - d_gt| / d_gt``, NaN when none evaluated); ``within_10pct``
        (fraction of evaluated points within 10 %); ``median_epe_px`` (median flow endpoint error of the
        tracked points against the flow predicted from ground-truth depth and motion); ``time_ms`` (the
        estimator's total time).

    Raises:
        FileNotFoundError: The folder, ``color/``, ``depth/``, ``trajectory.log`` or a frame's depth image is
            missing, or ``color/`` has no images.
        ValueError: ``max_gap`` is not a positive integer, the trajectory has fewer poses than frames, or
            images do not match ``intrinsics``.
    """
    if isinstance(max_gap, bool) or not isinstance(max_gap, (int, np.integer)) or max_gap < 1:
        raise ValueError(f"max_gap must be an integer >= 1, got {max_gap!r}")
    images, depth_paths, poses = _load_sequence(sequence_dir)
    estimator = FlowDepthEstimator(intrinsics, method=method, **estimator_params)
    rows = []
    for first in range(len(images)):
        true_depth = _read_depth(depth_paths[first])
        for second in range(first + 1, min(first + max_gap, len(images) - 1) + 1):
            rotation, translation = relative_motion(poses[first], poses[second])
            result = estimator.estimate(images[first], images[second], rotation, translation)
            rows.append(_pair_errors((first, second), result, true_depth, rotation, translation, intrinsics))
    return rows


def evaluate_stream(
    sequence_dir: Path,
    intrinsics: CameraIntrinsics,
    method: str = "triangulation",
    step: int = 1,
    # Passed straight on: FlowDepthEstimator checks each name and value.
    **estimator_params: Any,
) -> list[StreamPairErrors]:
    """Stream a sequence through :meth:`~estimator.FlowDepthEstimator.update` and measure every result.

    Frames ``0, step, 2·step, …`` are fed in order with their ground-truth motion, as a drone would feed its
    camera; each result (the depths of the frame before) is compared with that frame's ground-truth depth.
    This is how multi-frame depth (``baseline_frames`` > 1) is evaluated: its tracks need the stream.

    Args:
        sequence_dir, intrinsics, method: As :func:`evaluate_sequence`.
        step: Frames skipped between streamed frames plus one, an integer >= 1.
        **estimator_params: Further :class:`~estimator.FlowDepthEstimator` keyword arguments, e.g.
            ``baseline_frames``.

    Returns:
        One dict per streamed pair, with :func:`evaluate_sequence`'s keys plus ``baseline_frames`` (the mean
        baseline, in streamed frames, of the valid depths; 1 for two-frame estimation).

    Raises:
        As :func:`evaluate_sequence` (``step`` in place of ``max_gap``).
    """
    if isinstance(step, bool) or not isinstance(step, (int, np.integer)) or step < 1:
        raise ValueError(f"step must be an integer >= 1, got {step!r}")
    images, depth_paths, poses = _load_sequence(sequence_dir)
    estimator = FlowDepthEstimator(intrinsics, method=method, **estimator_params)
    frames = list(range(0, len(images), step))
    estimator.update(images[frames[0]], np.eye(3), np.zeros(3))
    rows: list[StreamPairErrors] = []
    for before, after in itertools.pairwise(frames):
        rotation, translation = relative_motion(poses[before], poses[after])
        result = estimator.update(images[after], rotation, translation)
        row = _pair_errors(
            (before, after), result, _read_depth(depth_paths[before]), rotation, translation, intrinsics
        )
        baselines = result.baseline_frames
        baseline = (
            float(np.mean(baselines[result.valid])) if baselines is not None and result.num_valid else 1.0
        )
        rows.append({**row, "baseline_frames": baseline})
    return rows


def format_error_table(rows: Sequence[Mapping[str, object]]) -> str:
    """Plain-text table of :func:`evaluate_sequence` rows, one line per pair and a median line.

    Args:
        rows: Rows from :func:`evaluate_sequence`.

    Returns:
        The table, columns aligned, without a trailing newline.
    """
    header = [title for _, title, _ in TABLE_COLUMNS]
    body = [[_format_cell(row[key], fmt) for key, _, fmt in TABLE_COLUMNS] for row in rows]
    if rows:
        summary = ["median"]
        for key, _, fmt in TABLE_COLUMNS[1:]:
            values = np.array([row[key] for row in rows], dtype=np.float64)
            finite = values[np.isfinite(values)]
            if len(finite) == 0:
                summary.append("-")
            elif fmt == "{:d}":
                summary.append(f"{np.median(finite):.0f}")
            else:
                summary.append(fmt.format(float(np.median(finite))))
        body.append(summary)
    widths = [max(len(line[column]) for line in [header, *body]) for column in range(len(header))]
    separator = ["-" * width for width in widths]
    return "\n".join(
        "  ".join(cell.rjust(width) for cell, width in zip(line, widths, strict=True))
        for line in [header, separator, *body]
    )


def _pair_errors(
    pair: tuple[int, int],
    result: DepthPoints,
    true_depth: np.ndarray,
    rotation: np.ndarray,
    translation: np.ndarray,
    intrinsics: CameraIntrinsics,
) -> PairErrors:
    # FAST keypoints lie on the pixel grid, so the ground truth is read at exactly the keypoint's pixel.
    pixel = np.rint(result.points).astype(np.intp)
    point_true_depth = true_depth[pixel[:, 1], pixel[:, 0]] if len(pixel) else np.empty(0)
    known = point_true_depth > 0.0

    evaluated = result.valid & known
    reference = point_true_depth[evaluated]
    relative_error = relative_depth_error(result.depth[evaluated], reference)

    with_flow = result.tracked & known
    predicted = predict_next_pixels(
        result.points[with_flow], point_true_depth[with_flow], rotation, translation, intrinsics.matrix
    )
    endpoint_error = np.linalg.norm(result.next_points[with_flow] - predicted, axis=1)
    endpoint_error = endpoint_error[np.isfinite(endpoint_error)]
    return {
        "pair": pair,
        "points": result.num_points,
        "tracked": result.num_tracked,
        "valid": result.num_valid,
        "evaluated": int(np.count_nonzero(evaluated)),
        "median_rel_error": float(np.median(relative_error)) if len(relative_error) else float("nan"),
        "within_10pct": float(np.mean(relative_error <= _WITHIN_FRACTION)) if len(relative_error) else 0.0,
        "median_epe_px": float(np.median(endpoint_error)) if len(endpoint_error) else float("nan"),
        "time_ms": 1000.0 * result.timings["total"],
    }


def _load_sequence(sequence_dir: Path) -> tuple[list[np.ndarray], list[Path], list[np.ndarray]]:
    """RGB frames, their depth image paths and camera-to-world poses, checked for completeness."""
    sequence_dir = Path(sequence_dir)
    if not sequence_dir.is_dir():
        raise FileNotFoundError(f"sequence folder not found: {sequence_dir}")
    color_paths = _color_frames(sequence_dir)
    depth_paths = [sequence_dir / "depth" / f"{path.stem}.png" for path in color_paths]
    for depth_path in depth_paths:
        if not depth_path.is_file():
            raise FileNotFoundError(f"depth image not found: {depth_path}")
    poses = read_trajectory_log(sequence_dir / "trajectory.log")
    if len(poses) < len(color_paths):
        raise ValueError(
            f"{sequence_dir / 'trajectory.log'} has {len(poses)} poses for {len(color_paths)} frames"
        )
    return [_read_color(path) for path in color_paths], depth_paths, poses


def _format_cell(value: object, fmt: str) -> str:
    if isinstance(value, float) and not np.isfinite(value):
        return "-"
    return fmt.format(value)


def _color_frames(sequence_dir: Path) -> list[Path]:
    color_dir = sequence_dir / "color"
    if not color_dir.is_dir():
        raise FileNotFoundError(f"color folder not found: {color_dir}")
    paths = sorted(path for path in color_dir.iterdir() if path.suffix.lower() in _COLOR_SUFFIXES)
    if not paths:
        raise FileNotFoundError(f"no .jpg or .png frames in {color_dir}")
    return paths


def _read_color(path: Path) -> np.ndarray:
    image = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if image is None:
        raise ValueError(f"cannot decode image {path}")
    return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)


def _read_depth(path: Path) -> np.ndarray:
    depth = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if depth is None:
        raise ValueError(f"cannot decode depth image {path}")
    if depth.dtype != np.uint16 or depth.ndim != 2:
        raise ValueError(
            f"{path} must be a single-channel uint16 PNG in millimetres, got {depth.dtype} {depth.shape}"
        )
    return depth.astype(np.float64) / _MILLIMETRES_PER_METRE
