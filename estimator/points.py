"""The estimator's per-frame result: one row per keypoint of the previous frame."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

TIMING_KEYS = ("prepare", "fast", "flow", "depth", "total")


@dataclass
class DepthPoints:
    """Result of one estimation: one row per FAST keypoint of the previous frame.

    Attributes:
        points: (N, 2) float32 keypoint pixel positions in the previous image.
        next_points: (N, 2) float32 tracked positions in the next image; meaningless where ``tracked`` is
            False.
        depth: (N,) float64 z-depth in metres in the previous camera frame. Finite and positive where
            ``valid``; may be NaN, negative or meaningless elsewhere.
        valid: (N,) bool: the depth passed every check (tracking and geometry).
        tracked: (N,) bool: LK converged, its error is within ``max_lk_error`` and the forward-backward check
            (when on) passed. ``valid`` implies ``tracked``.
        parallax_px: (N,) float64 translational flow (after derotation) behind the depth, in pixels.
        timings: Seconds per stage: ``"prepare"`` (grayscale conversion and brightness normalisation of the
            new frame, and of the previous one in :meth:`FlowDepthEstimator.estimate`), ``"fast"``, ``"flow"``
            (pyramidal LK, both directions), ``"depth"`` (derotation, depth and checks) and ``"total"`` (the
            whole call, including input checks).
        baseline_frames: (N,) int16, the frames between the image each depth was ranged from and the next
            image (see ``FlowDepthEstimator(baseline_frames=...)``); None when every depth spans one frame
            pair.
    """

    points: np.ndarray
    next_points: np.ndarray
    depth: np.ndarray
    valid: np.ndarray
    tracked: np.ndarray
    parallax_px: np.ndarray
    timings: dict[str, float] = field(default_factory=lambda: dict.fromkeys(TIMING_KEYS, 0.0))
    baseline_frames: np.ndarray | None = None

    @classmethod
    def empty(cls, timings: dict[str, float] | None = None) -> DepthPoints:
        """A result with no points (first frame of a stream, or a frame without corners)."""
        return cls(
            points=np.empty((0, 2), dtype=np.float32),
            next_points=np.empty((0, 2), dtype=np.float32),
            depth=np.empty(0, dtype=np.float64),
            valid=np.empty(0, dtype=bool),
            tracked=np.empty(0, dtype=bool),
            parallax_px=np.empty(0, dtype=np.float64),
            timings=dict(timings) if timings is not None else dict.fromkeys(TIMING_KEYS, 0.0),
        )

    @property
    def num_points(self) -> int:
        """Number of keypoints detected in the previous frame (N)."""
        return len(self.points)

    @property
    def num_tracked(self) -> int:
        """Number of keypoints that were tracked into the next frame (``tracked.sum()``)."""
        return int(np.count_nonzero(self.tracked))

    @property
    def num_valid(self) -> int:
        """Number of keypoints with a trusted depth (``valid.sum()``)."""
        return int(np.count_nonzero(self.valid))
