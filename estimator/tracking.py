"""Image side of the estimator: image checks, brightness normalisation, FAST keypoints, pyramidal LK.

These wrap OpenCV and turn its outputs into plain arrays; the geometry lives in :mod:`estimator.geometry`.

Why images and not pyramids go into LK: OpenCV's Python bindings cannot pass the output of
``cv2.buildOpticalFlowPyramid`` to ``cv2.calcOpticalFlowPyrLK`` (its ``InputArray`` accepts one array, not a
list; opencv/opencv#4777, open since 2014, still so in OpenCV 5.0). ``calcOpticalFlowPyrLK`` therefore builds
the pyramids itself. Measured at 640×480 on one core, that internal work is about 0.3 ms per call (both
images, max level 3), against about 4 µs per tracked point; prebuilding with derivatives would cost 2.4 ms.
What a stream can reuse, and does, is each frame's prepared image (grayscale conversion and brightness
normalisation) and its FAST corners' source.
"""

from __future__ import annotations

from typing import NamedTuple

import cv2
import numpy as np

# Target statistics of brightness normalisation. A standard deviation of 48 grey levels is about the
# contrast of typical indoor frames (ICL-NUIM: 45-48), so LK's error keeps its usual scale against
# max_lk_error. Measured on ICL-NUIM 0->2 / 0->4: lower targets (40, 32, 24) pass more points through the LK
# error check but raise the flow error (median EPE 0.33 -> 0.35, 0.40, 0.49 px at 0->4, quantisation).
_NORMALIZED_MEAN = 128.0
_NORMALIZED_STD = 48.0
# LK stops after this many iterations or when the update is below this many pixels (OpenCV's defaults).
_LK_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 30, 0.01)


BRIGHTNESS_MODES = ("pair", "frame", "off")


class PreparedFrame(NamedTuple):
    """What one frame contributes, prepared once: its grayscale and its own brightness map (gain, offset)."""

    gray: np.ndarray
    brightness_map: tuple[float, float]


def tracking_images(
    previous: PreparedFrame, current: PreparedFrame, mode: str
) -> tuple[np.ndarray, np.ndarray]:
    """The two images FAST and LK work on, per the estimator's ``normalize_brightness`` mode: ``"off"`` the raw
    frames, ``"pair"`` both mapped with the previous frame's map, ``"frame"`` each with its own."""
    if mode == "off":
        return previous.gray, current.gray
    next_map = previous.brightness_map if mode == "pair" else current.brightness_map
    return (
        apply_brightness_map(previous.gray, *previous.brightness_map),
        apply_brightness_map(current.gray, *next_map),
    )


class Tracks(NamedTuple):
    """Output of :func:`track_points`; N rows, one per input point.

    Attributes:
        next_points: (N, 2) float32 tracked positions in the next image (meaningless where not ``status``).
        status: (N,) bool, LK converged for the point.
        lk_error: (N,) float32, LK's mean absolute intensity difference over the window (grey levels).
        fb_error_px: (N,) float32 forward-backward error in pixels; 0 when the check is off, inf where the
            backward track failed.
    """

    next_points: np.ndarray
    status: np.ndarray
    lk_error: np.ndarray
    fb_error_px: np.ndarray


def to_grayscale(image: object, name: str, expected_size: tuple[int, int] | None = None) -> np.ndarray:
    """Validate an image and return it as a C-contiguous uint8 (H, W) array.

    Args:
        image: uint8 array, grayscale (H, W) or RGB (H, W, 3).
        name: Argument name for error messages.
        expected_size: ``(width, height)`` the image must have, or None to accept any size.

    Returns:
        The grayscale image (the input itself when it already is contiguous grayscale).

    Raises:
        ValueError: Not a numpy array, not uint8, wrong number of dimensions or channels, empty, or not of
            ``expected_size``.
    """
    if not isinstance(image, np.ndarray):
        raise ValueError(
            f"{name} must be a numpy uint8 array of shape (H, W) or (H, W, 3), got {type(image).__name__}"
        )
    if image.dtype != np.uint8:
        raise ValueError(f"{name} must have dtype uint8, got {image.dtype}")
    if not (image.ndim == 2 or (image.ndim == 3 and image.shape[2] == 3)):
        raise ValueError(f"{name} must have shape (H, W) or (H, W, 3), got {image.shape}")
    height, width = image.shape[:2]
    if height == 0 or width == 0:
        raise ValueError(f"{name} must not be empty, got shape {image.shape}")
    if expected_size is not None and (width, height) != tuple(expected_size):
        raise ValueError(
            f"{name} must be {expected_size[0]}x{expected_size[1]} (width x height) to match the camera "
            f"intrinsics, got {width}x{height}"
        )
    if image.ndim == 3:
        return cv2.cvtColor(np.ascontiguousarray(image), cv2.COLOR_RGB2GRAY)
    return np.ascontiguousarray(image)


def brightness_map(gray: np.ndarray) -> tuple[float, float]:
    """Gain and offset of the affine map taking a frame to a fixed mean (128) and standard deviation (48).

    Flat frames (std < 1) are only shifted.
    """
    mean_matrix, std_matrix = cv2.meanStdDev(gray)
    mean, std = float(mean_matrix[0, 0]), float(std_matrix[0, 0])
    gain = _NORMALIZED_STD / std if std >= 1.0 else 1.0
    return gain, _NORMALIZED_MEAN - gain * mean


def apply_brightness_map(gray: np.ndarray, gain: float, offset: float) -> np.ndarray:
    """``gain · gray + offset`` saturated to uint8."""
    # addWeighted computes in float and saturates to uint8 in one pass, faster than numpy round-tripping.
    return cv2.addWeighted(gray, gain, gray, 0.0, offset)


def normalize_brightness(gray: np.ndarray) -> np.ndarray:
    """Affine intensity map of a frame to a fixed mean and standard deviation (its own :func:`brightness_map`).

    LK assumes brightness constancy. An exposure or gain change between frames (auto-exposure, flicker,
    flying into shade; thesis §5.2.3) breaks it; mapping every frame to the same mean and standard deviation
    undoes any global gain-and-offset change. A percentile stretch was tried instead and rejected: the
    percentiles move with the frame's content, so the stretch itself broke brightness constancy between
    frames (valid points 0->4 fell from 292 to 31). The mean and standard deviation move with the content too
    (sky replacing ground as the camera pitches), which is why the estimator's default ``"pair"`` mode maps
    both frames of a pair with the previous frame's map instead.

    Args:
        gray: uint8 (H, W) image.

    Returns:
        uint8 (H, W) image with mean ~128 and std ~48 (saturated at 0 and 255).
    """
    return apply_brightness_map(gray, *brightness_map(gray))


def detect_keypoints(
    gray: np.ndarray,
    detector: cv2.FastFeatureDetector,
    max_points: int | None,
    spread_grid: tuple[int, int] | None,
    mask: np.ndarray | None = None,
) -> np.ndarray:
    """FAST corners of a frame, optionally limited in number and spread over the image.

    Args:
        gray: uint8 (H, W) image.
        detector: A configured ``cv2.FastFeatureDetector``.
        max_points: Keep at most this many (the strongest by FAST response), or None for all.
        spread_grid: ``(rows, cols)`` grid for spreading, or None for plain strongest-first selection. With a
            grid, the kept points are balanced over the cells: every cell keeps its strongest corners up to a
            common cap, the cap chosen as small as possible while still giving ``max_points`` in total, so
            sparse cells keep everything and crowded cells (texture) give way.
        mask: uint8 (H, W), detect only where it is non-zero; None for the whole image.

    Returns:
        (N, 2) float32 pixel positions (integers: FAST works on the pixel grid).
    """
    keypoints = detector.detect(gray, mask)
    if not keypoints:
        return np.empty((0, 2), dtype=np.float32)
    points = np.asarray(cv2.KeyPoint.convert(keypoints), dtype=np.float32).reshape(-1, 2)
    if max_points is None or len(points) <= max_points:
        return points
    # Reading the response is the one per-keypoint access OpenCV leaves us (cv2.KeyPoint is a Python object).
    response = np.fromiter((keypoint.response for keypoint in keypoints), np.float32, len(keypoints))
    if spread_grid is None:
        keep = np.argpartition(-response, max_points - 1)[:max_points]
    else:
        keep = _balanced_selection(points, response, gray.shape[1], gray.shape[0], max_points, spread_grid)
    return points[np.sort(keep)]


def _balanced_selection(
    points: np.ndarray,
    response: np.ndarray,
    width: int,
    height: int,
    max_points: int,
    grid: tuple[int, int],
) -> np.ndarray:
    rows, cols = grid
    cell_col = np.minimum((points[:, 0] * cols / width).astype(np.intp), cols - 1)
    cell_row = np.minimum((points[:, 1] * rows / height).astype(np.intp), rows - 1)
    cell = cell_row * cols + cell_col
    # Order by cell, strongest first inside each cell, then each point's rank within its cell.
    order = np.lexsort((-response, cell))
    sorted_cell = cell[order]
    cell_start = np.searchsorted(sorted_cell, sorted_cell, side="left")
    rank = np.empty(len(points), dtype=np.intp)
    rank[order] = np.arange(len(points)) - cell_start
    # Smallest cap with sum(min(count, cap)) >= max_points; kept(cap) is monotone: search the sorted counts.
    counts = np.sort(np.bincount(cell, minlength=rows * cols))
    kept_below = np.concatenate([[0], np.cumsum(counts)[:-1]])  # points in cells smaller than counts[k]
    kept_at_cap = kept_below + counts * (len(counts) - np.arange(len(counts)))
    index = int(np.searchsorted(kept_at_cap, max_points, side="left"))
    if index == 0:
        cap = int(np.ceil(max_points / len(counts)))
    else:
        remaining = max_points - kept_below[index]
        cap = int(np.ceil(remaining / (len(counts) - index)))
    candidates = np.flatnonzero(rank < cap)
    if len(candidates) > max_points:
        # The last round of the cap overshoots; drop the weakest of the points at the cap's rank.
        at_cap = candidates[rank[candidates] == cap - 1]
        below_cap = candidates[rank[candidates] < cap - 1]
        needed = max_points - len(below_cap)
        strongest_at_cap = at_cap[np.argsort(-response[at_cap], kind="stable")[:needed]]
        candidates = np.concatenate([below_cap, strongest_at_cap])
    return candidates


def track_points(
    prev_image: np.ndarray,
    next_image: np.ndarray,
    points: np.ndarray,
    win_size: int,
    max_level: int,
    forward_backward: bool,
    backward_max_level: int | None = None,
) -> Tracks:
    """Pyramidal Lucas-Kanade from the previous into the next frame, optionally checked backwards.

    Args:
        prev_image: Previous frame, uint8 (H, W).
        next_image: Next frame, uint8 (H, W).
        points: (N, 2) float32 pixel positions in the previous frame.
        win_size: LK window side in pixels.
        max_level: Highest pyramid level used (0 = full resolution only).
        forward_backward: Also track the result back into the previous frame and report how far it lands
            from where it started.

    Returns:
        :class:`Tracks`.
    """
    count = len(points)
    if count == 0:
        empty = np.empty(0, dtype=np.float32)
        return Tracks(np.empty((0, 2), dtype=np.float32), np.empty(0, dtype=bool), empty, empty.copy())
    points = np.ascontiguousarray(points, dtype=np.float32).reshape(-1, 1, 2)
    window = (win_size, win_size)
    next_points, status, lk_error = cv2.calcOpticalFlowPyrLK(
        prev_image, next_image, points, None, winSize=window, maxLevel=max_level, criteria=_LK_CRITERIA
    )
    status = status.reshape(count).astype(bool)
    lk_error = lk_error.reshape(count).astype(np.float32)
    fb_error = np.zeros(count, dtype=np.float32)
    if forward_backward:
        if backward_max_level is None:
            back_points, back_status, _ = cv2.calcOpticalFlowPyrLK(
                next_image,
                prev_image,
                next_points,
                None,
                winSize=window,
                maxLevel=max_level,
                criteria=_LK_CRITERIA,
            )
        else:
            # A correct forward track leads straight back to where it started: search the backward match
            # from there, on few pyramid levels, instead of repeating the forward search from scratch.
            back_points, back_status, _ = cv2.calcOpticalFlowPyrLK(
                next_image,
                prev_image,
                next_points,
                points.copy(),
                winSize=window,
                maxLevel=backward_max_level,
                criteria=_LK_CRITERIA,
                flags=cv2.OPTFLOW_USE_INITIAL_FLOW,
            )
        distance = np.linalg.norm((back_points - points).reshape(count, 2), axis=1).astype(np.float32)
        fb_error = np.where(back_status.reshape(count).astype(bool), distance, np.float32(np.inf))
    return Tracks(next_points.reshape(count, 2), status, lk_error, fb_error)
