"""Depth over baselines of several frames: points tracked frame to frame, ranged from their oldest view.

Two frames 0.1 m apart give far points, and points near the focus of expansion, too little parallax for a
depth. A point tracked over k frames moves k times as far, so it is ranged from the oldest frame it was seen in
(within ``baseline_frames``), with the told motions of the frames in between composed. The depth is then
carried to the previous frame, so a result means what a two-frame result means: the z-depth of the previous
frame's points in the previous camera frame.

Tracking stays frame to frame (one LK pass per frame, as with two frames): tracks that pass the tracking checks
are carried over, new FAST corners fill the image away from them. The pure kernels here (motion composition,
ranging by baseline, the detection mask) take plain arrays; :class:`TrackWindow` holds the tracks between
frames.
"""

from __future__ import annotations

from typing import NamedTuple

import cv2
import numpy as np

from estimator import geometry

#: A rigid motion between two camera frames, ``X_to = R @ X_from + t``.
Motion = tuple[np.ndarray, np.ndarray]

_IDENTITY: Motion = (np.eye(3), np.zeros(3))


def compose(first: Motion, then: Motion) -> Motion:
    """The motion ``first`` followed by ``then``: ``X = R_then (R_first X + t_first) + t_then``."""
    rotation_first, translation_first = first
    rotation_then, translation_then = then
    return rotation_then @ rotation_first, rotation_then @ translation_first + translation_then


def motions_to_latest(steps_newest_first: list[Motion], count: int) -> list[Motion]:
    """Motions from each of the last ``count`` frames to the latest one.

    Args:
        steps_newest_first: per-frame motions, the newest (into the latest frame) first.
        count: how many frames back, at most ``len(steps_newest_first) + 1``.

    Returns:
        ``count`` motions: entry ``a`` maps frame ``latest - a`` to the latest frame (entry 0 the identity).
    """
    motions = [_IDENTITY]
    for step in steps_newest_first[: count - 1]:
        motions.append(compose(step, motions[-1]))
    return motions


class Ranging(NamedTuple):
    """Depths of tracked points ranged over several baselines; every field (N,).

    Attributes:
        depth: z-depth (m) in the camera of the frame before the newest, NaN where undefined.
        parallax_px: translational flow over the baseline the depth came from, pixels.
        ok: the geometry checks passed (parallax, epipolar line, in front of every camera involved).
        off_epipolar: the point is off its epipolar line by more than allowed: the track has drifted or
            mistracked. False where the motion gives no line (no translation).
    """

    depth: np.ndarray
    parallax_px: np.ndarray
    ok: np.ndarray
    off_epipolar: np.ndarray


def range_over_baselines(
    anchor_normalized: np.ndarray,
    next_normalized: np.ndarray,
    baseline: np.ndarray,
    to_previous: list[Motion],
    step: Motion,
    focal_scale: np.ndarray,
    method: str,
    min_parallax_px: float,
    max_epipolar_error_px: float,
) -> Ranging:
    """Depth of each point from its anchor view ``baseline`` frames before the next image.

    Args:
        anchor_normalized: (N, 2) normalised positions in each point's anchor frame.
        next_normalized: (N, 2) normalised positions in the next frame.
        baseline: (N,) int, frames from the anchor to the next frame (1 = the previous frame).
        to_previous: motions from the frame ``a + 1`` frames before the next one to the previous frame, for
            ``a`` = 0 … ``baseline.max() - 1`` (:func:`motions_to_latest` of the stored steps).
        step: motion from the previous to the next frame.
        focal_scale: (2,) ``[fx, fy]`` in pixels.
        method: as :func:`estimator.geometry.solve_depth`.
        min_parallax_px, max_epipolar_error_px: as :func:`estimator.geometry.valid_depth_mask`.

    Returns:
        A :class:`Ranging`.
    """
    count = len(baseline)
    depth = np.full(count, np.nan)
    parallax = np.zeros(count)
    ok = np.zeros(count, bool)
    off_epipolar = np.zeros(count, bool)
    for frames in np.unique(baseline):
        rows = np.flatnonzero(baseline == frames)
        anchor_to_previous = to_previous[frames - 1]
        rotation, translation = compose(anchor_to_previous, step)
        solution = geometry.solve_depth(
            anchor_normalized[rows], next_normalized[rows], rotation, translation, focal_scale, method
        )
        # The anchor-frame point carried into the previous camera: its z there is the reported depth.
        (r20, r21, r22), t_z = anchor_to_previous[0][2], anchor_to_previous[1][2]
        x, y = anchor_normalized[rows, 0], anchor_normalized[rows, 1]
        depth[rows] = solution.depth * (r20 * x + r21 * y + r22) + t_z
        parallax[rows] = solution.parallax_px
        error = solution.epipolar_error_px
        with np.errstate(invalid="ignore"):
            off_epipolar[rows] = np.isfinite(error) & (error > max_epipolar_error_px)
            ok[rows] = geometry.valid_depth_mask(solution, min_parallax_px, max_epipolar_error_px) & (
                depth[rows] > 0.0
            )
    return Ranging(depth, parallax, ok, off_epipolar)


def free_mask(shape: tuple[int, int], points: np.ndarray, radius_px: int) -> np.ndarray | None:
    """uint8 detection mask: 0 within ``radius_px`` (square) of any of ``points`` (N, 2), 255 elsewhere;
    None when there are no points (detect everywhere)."""
    if len(points) == 0:
        return None
    height, width = shape
    columns = np.clip(np.rint(points[:, 0]).astype(np.intp), 0, width - 1)
    rows = np.clip(np.rint(points[:, 1]).astype(np.intp), 0, height - 1)
    occupied = np.zeros(shape, np.uint8)
    occupied[rows, columns] = 255
    side = 2 * radius_px + 1
    occupied = cv2.dilate(occupied, np.ones((side, side), np.uint8))
    return cv2.bitwise_not(occupied)


class TrackWindow:
    """Tracks alive in the latest frame, their positions over the last frames and the motions between them.

    Positions are stored newest first: column 0 is the latest frame, column ``j`` the frame ``j`` before it;
    a track seen in ``n`` frames has its oldest view in column ``n - 1`` (NaN beyond).

    Args:
        baseline_frames: the longest baseline a depth may span, in frames (≥ 2; 1 is two-frame estimation).
    """

    def __init__(self, baseline_frames: int) -> None:
        self.baseline_frames = baseline_frames
        self.reset()

    def reset(self) -> None:
        """Forget every track and motion."""
        self.positions = np.empty((0, self.baseline_frames, 2), np.float32)
        self.seen_frames = np.empty(0, np.int16)
        self.steps: list[Motion] = []

    @property
    def latest_points(self) -> np.ndarray:
        """(N, 2) float32 positions of the live tracks in the latest frame."""
        return self.positions[:, 0]

    def add(self, points: np.ndarray) -> None:
        """Start tracks at new detections ``points`` (M, 2) of the latest frame."""
        new = np.full((len(points), self.baseline_frames, 2), np.nan, np.float32)
        new[:, 0] = points
        self.positions = np.concatenate([self.positions, new])
        self.seen_frames = np.concatenate([self.seen_frames, np.ones(len(points), np.int16)])

    def anchors(self) -> tuple[np.ndarray, np.ndarray]:
        """Each track's oldest view in the window: ``(positions (N, 2), frames back from the latest (N,))``.

        The baseline to a new frame is one more than the frames back.
        """
        back = self.seen_frames.astype(np.intp) - 1
        return self.positions[np.arange(len(back)), back], back

    def advance(self, next_points: np.ndarray, keep: np.ndarray, step: Motion) -> None:
        """Move to a new frame: tracks where ``keep`` continue at ``next_points``, the others end.

        Args:
            next_points: (N, 2) positions of every live track in the new frame.
            keep: (N,) bool, the tracks that continue.
            step: told motion from the latest frame to the new one.
        """
        kept = self.positions[keep]
        self.positions = np.concatenate([next_points[keep][:, None], kept[:, :-1]], axis=1)
        # Only the oldest view in the window matters, so the count saturates there.
        self.seen_frames = np.minimum(self.seen_frames[keep] + 1, self.baseline_frames).astype(np.int16)
        self.steps = [step, *self.steps[: self.baseline_frames - 2]]
