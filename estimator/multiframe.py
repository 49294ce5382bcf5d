"""Depth over baselines of several frames: points tracked frame to frame, ranged from their oldest view.

Two frames 0.1 m apart give far points, and points near the focus of expansion, too little parallax for a
depth. A point tracked over k frames moves k times as far, so it is ranged from the oldest frame it was seen in
(within ``baseline_frames``), with the told motions of the frames in between composed. The depth is then
carried to the previous frame, so a result means what a two-frame result means: the z-depth of the previous
frame's points in the previous camera frame.

Tracking stays frame to frame (one LK pass per frame, as with two frames): each frame's FAST corners are the
points ranged, as with two frames, and a corner found again where a track was followed to continues that
track, with its older views. The pure kernels here (motion composition, ranging by baseline, nearest-track
lookup) take plain arrays; :class:`TrackWindow` holds the tracks between frames.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from estimator import geometry

#: A rigid motion between two camera frames, ``X_to = R @ X_from + t``.
Motion = tuple[np.ndarray, np.ndarray]

_IDENTITY: Motion = (np.eye(3), np.zeros(3))
#: A corner found again within this many pixels of where a track was followed to is that track: FAST puts
#: corners on the pixel grid, LK follows them to sub-pixel positions, and FAST's own localisation wobbles.
MATCH_RADIUS_PX = 1.5


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
    """Depths of tracked points, each from the longest baseline that passes the checks; every field (N,).

    Attributes:
        depth: z-depth (m) in the camera of the frame before the newest, NaN where undefined.
        parallax_px: translational flow over the baseline the depth came from, pixels.
        ok: the geometry checks passed (parallax, epipolar line, in front of every camera involved).
        baseline: frames the depth spans: the track's anchor where that passed the checks, else 1.
        off_epipolar: off its epipolar line over the last frame pair by more than allowed: a mistrack. False
            where the motion gives no line (no translation).
        drifted: fine over the last frame pair but off the line from its anchor: the track's history has
            drifted (or its older motions were told wrong), so it should start afresh.
    """

    depth: np.ndarray
    parallax_px: np.ndarray
    ok: np.ndarray
    baseline: np.ndarray
    off_epipolar: np.ndarray
    drifted: np.ndarray


def range_over_baselines(
    anchor_normalized: np.ndarray,
    previous_normalized: np.ndarray,
    next_normalized: np.ndarray,
    anchor_baseline: np.ndarray,
    to_previous: list[Motion],
    step: Motion,
    focal_scale: np.ndarray,
    method: str,
    min_parallax_px: float,
    max_epipolar_error_px: float,
) -> Ranging:
    """Depth of each point from its anchor view, ``anchor_baseline`` frames before the next image, or from
    the previous frame where the long baseline fails a check.

    The long baseline fails where a track has drifted along the way, or on near surfaces whose look changes
    over the frames; one frame pair still ranges those, as the two-frame estimator would.

    Args:
        anchor_normalized: (N, 2) normalised positions in each point's anchor frame.
        previous_normalized: (N, 2) normalised positions in the previous frame.
        next_normalized: (N, 2) normalised positions in the next frame.
        anchor_baseline: (N,) int, frames from the anchor to the next frame (1: the anchor is the previous
            frame).
        to_previous: motions from the frame ``a + 1`` frames before the next one to the previous frame, for
            ``a`` = 0 … ``anchor_baseline.max() - 1`` (:func:`motions_to_latest` of the stored steps).
        step: motion from the previous to the next frame.
        focal_scale: (2,) ``[fx, fy]`` in pixels.
        method: as :func:`estimator.geometry.solve_depth`.
        min_parallax_px, max_epipolar_error_px: as :func:`estimator.geometry.valid_depth_mask`.

    Returns:
        A :class:`Ranging`.
    """
    single = geometry.solve_depth(previous_normalized, next_normalized, *step, focal_scale, method)
    with np.errstate(invalid="ignore"):
        ok = geometry.valid_depth_mask(single, min_parallax_px, max_epipolar_error_px)
        error = single.epipolar_error_px
        off_epipolar = np.isfinite(error) & (error > max_epipolar_error_px)
    depth, parallax = single.depth.copy(), single.parallax_px.copy()
    baseline = np.ones(len(anchor_baseline), np.int16)
    drifted = np.zeros(len(anchor_baseline), bool)
    for frames in np.unique(anchor_baseline[anchor_baseline > 1]):
        rows = np.flatnonzero(anchor_baseline == frames)
        anchor_to_previous = to_previous[frames - 1]
        rotation, translation = compose(anchor_to_previous, step)
        solution = geometry.solve_depth(
            anchor_normalized[rows], next_normalized[rows], rotation, translation, focal_scale, method
        )
        # The anchor-frame point carried into the previous camera: its z there is the reported depth.
        (r20, r21, r22), t_z = anchor_to_previous[0][2], anchor_to_previous[1][2]
        x, y = anchor_normalized[rows, 0], anchor_normalized[rows, 1]
        long_depth = solution.depth * (r20 * x + r21 * y + r22) + t_z
        with np.errstate(invalid="ignore"):
            long_ok = geometry.valid_depth_mask(solution, min_parallax_px, max_epipolar_error_px)
            long_ok &= long_depth > 0.0
            long_error = solution.epipolar_error_px
            drifted[rows] = (
                np.isfinite(long_error) & (long_error > max_epipolar_error_px) & ~off_epipolar[rows]
            )
        chosen = rows[long_ok]
        depth[chosen] = long_depth[long_ok]
        parallax[chosen] = solution.parallax_px[long_ok]
        baseline[chosen] = frames
        ok[chosen] = True
    return Ranging(depth, parallax, ok, baseline, off_epipolar, drifted)


def nearest_within(points: np.ndarray, candidates: np.ndarray, radius_px: float) -> np.ndarray:
    """Index of the nearest of ``candidates`` (K, 2) within ``radius_px`` of each of ``points`` (M, 2), or -1.

    Candidates are put on the pixel grid and looked up in the square around each point, all points and
    offsets at once (no per-point loop, and no K × M distance matrix at a thousand points).
    """
    result = np.full(len(points), -1, np.intp)
    finite = np.all(np.isfinite(candidates), axis=1) if len(candidates) else np.zeros(0, bool)
    if not len(points) or not finite.any():
        return result
    # Corners lie on the pixel grid; a candidate within the radius rounds to a cell at most half a pixel further.
    reach = int(np.ceil(radius_px + 0.5))
    index = np.flatnonzero(finite)
    cells = np.rint(candidates[index]).astype(np.intp)
    origin = cells.min(axis=0) - reach
    width, height = cells.max(axis=0) - origin + reach + 1
    grid = np.full((height, width), -1, np.intp)
    grid[cells[:, 1] - origin[1], cells[:, 0] - origin[0]] = index
    offsets = np.arange(-reach, reach + 1)
    x = (np.rint(points[:, 0]).astype(np.intp) - origin[0])[:, None, None] + offsets[None, None, :]
    y = (np.rint(points[:, 1]).astype(np.intp) - origin[1])[:, None, None] + offsets[None, :, None]
    inside = (x >= 0) & (x < width) & (y >= 0) & (y < height)
    found = np.where(inside, grid[np.clip(y, 0, height - 1), np.clip(x, 0, width - 1)], -1).reshape(
        len(points), -1
    )
    padded = np.concatenate([candidates.astype(np.float32), np.full((1, 2), np.inf, np.float32)])  # -1: none
    offset = padded[found] - np.asarray(points, np.float32)[:, None, :]
    distance = np.sqrt(offset[..., 0] ** 2 + offset[..., 1] ** 2)
    nearest = np.argmin(distance, axis=1)
    best = distance[np.arange(len(points)), nearest]
    chosen = best <= radius_px
    result[chosen] = found[chosen, nearest[chosen]]
    return result


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

    def adopt(self, corners: np.ndarray, radius_px: float = MATCH_RADIUS_PX) -> None:
        """Make the latest frame's corners (M, 2) the tracks: a corner within ``radius_px`` of a live track's
        latest position is that track found again, which goes on (its position and older views); the other
        corners start afresh, and tracks no corner found end.

        Tracks follow the corners rather than the other way round, so the points ranged are those a two-frame
        estimator would range (a continued track at its own sub-pixel position); only their baselines grow.
        """
        count = len(corners)
        adopted = np.full((count, self.baseline_frames, 2), np.nan, np.float32)
        adopted[:, 0] = corners
        seen = np.ones(count, np.int16)
        match = nearest_within(corners, self.latest_points, radius_px)
        found = match >= 0
        # A found track keeps its own position, not the corner's: its older views were followed from there, and
        # the corner's pixel-grid position can be a pixel off, which over a long baseline is a depth error.
        adopted[found] = self.positions[match[found]]
        seen[found] = self.seen_frames[match[found]]
        self.positions, self.seen_frames = adopted, seen

    def anchors(self) -> tuple[np.ndarray, np.ndarray]:
        """Each track's oldest view in the window: ``(positions (N, 2), frames back from the latest (N,))``.

        The baseline to a new frame is one more than the frames back.
        """
        back = self.seen_frames.astype(np.intp) - 1
        return self.positions[np.arange(len(back)), back], back

    def advance(
        self, next_points: np.ndarray, keep: np.ndarray, step: Motion, restart: np.ndarray | None = None
    ) -> None:
        """Move to a new frame: tracks where ``keep`` continue at ``next_points``, the others end.

        Args:
            next_points: (N, 2) positions of every live track in the new frame.
            keep: (N,) bool, the tracks that continue.
            step: told motion from the latest frame to the new one.
            restart: (N,) bool, continuing tracks that forget their views before the latest frame.
        """
        if restart is not None and restart.any():
            self.positions[restart, 1:] = np.nan
            self.seen_frames[restart] = 1
        kept = self.positions[keep]
        self.positions = np.concatenate([next_points[keep][:, None], kept[:, :-1]], axis=1)
        # Only the oldest view in the window matters, so the count saturates there.
        self.seen_frames = np.minimum(self.seen_frames[keep] + 1, self.baseline_frames).astype(np.int16)
        self.steps = [step, *self.steps[: self.baseline_frames - 2]]
