"""The flow depth estimator: FAST → pyramidal LK → derotation → depth from the known translation."""

from __future__ import annotations

import time

import cv2
import numpy as np
from numpy.typing import ArrayLike

from estimator import geometry, multiframe, tracking
from estimator._validation import (
    as_grid,
    as_rotation_matrix,
    as_translation_vector,
    require_bool,
    require_int_in_range,
    require_non_negative_finite,
    require_positive_finite,
)
from estimator.camera import CameraIntrinsics
from estimator.points import TIMING_KEYS, DepthPoints


class FlowDepthEstimator:
    """Sparse depth from optical flow and known camera motion (the thesis's estimator).

    Pipeline per frame pair: FAST corners in the previous frame → pyramidal Lucas-Kanade into the next frame
    (optionally checked backwards) → derotation with the known rotation → depth from the remaining,
    translational flow and the known translation → validity checks.

    Conventions: images are uint8 grayscale (H, W) or RGB (H, W, 3) of the intrinsics' size; the motion from
    the previous to the next camera frame is ``X_next = R @ X_prev + t`` in the OpenCV camera frame (x right,
    y down, z forward), metres; depth is the z-depth in the previous camera frame.

    Defaults and the measurements behind them (ICL-NUIM living room 1, frames 0→2 / 0→4 with ground-truth
    motion, 640×480; figures are median relative depth error / valid points; Middlebury RubberWhale for the
    flow stage; timings on a shared 2-core machine):

    * Thesis settings: LK window 10×10, max pyramid level 3, max LK error 5.
    * Result with all defaults: triangulation 0.88 % / 436 and 0.54 % / 292; the thesis method agrees to
      two digits (ICL-NUIM's motion is mostly along y, so both methods lean on the same flow component, and
      the epipolar check keeps only points where the two components agree).
      95 % of valid depths are within 10 %. RubberWhale median LK endpoint error 0.033 px.
      Streaming at 640×480 (726 corners): prepare 0.1-0.2 ms, FAST 0.3 ms, flow 3.5-5.8 ms (LK both ways),
      depth 0.3 ms, total 4.4-7 ms; bare ``FAST + calcOpticalFlowPyrLK`` on the same frames 1.9-2.4 ms.
    * ``fast_threshold=20`` (not stated for the thesis; chosen by measurement): accuracy is flat in the
      threshold (median 0.79-0.96 % for 10-40), the point count is not: 10 → 617 / 367 valid (capped by
      ``max_points``), 20 → 401 / 234, 30 → 150 / 85, 40 → 59 / 38 (too few at 0→4). 20 keeps several hundred
      points at about half the time of 10.
    * ``max_points=1000``: bounds the per-frame time in textured scenes (LK costs about 4 µs per point per
      direction); ICL-NUIM at threshold 20 stays below it (726 corners).
    * ``spread_keypoints=True`` on a 6×8 grid: at equal point budgets (threshold 10) it raises the share of
      6×8 image cells holding a valid depth from 54 / 42 % to 79 / 58 % (250 points) and from 75 / 58 % to
      88 / 75 % (500 points), and gives 9-25 % more valid points, at unchanged accuracy (0.79 vs 0.96 %
      median at 250 points).
    * ``forward_backward=True``, ``fb_max_error_px=0.5``: share of depths within 10 % at 0→4 rises from
      91.8 % (off) to 95.3 %, flow endpoint error 0.233 → 0.221 px, for 6-12 % fewer valid points; it
      doubles the LK time. 0.25 px / 0.1 px trade more points (-4 / -11 %) for 95.5 / 96.6 %; 1-2 px
      barely filter.
    * ``normalize_brightness="off"`` (the thesis's setting). Measured alternatives: ``"frame"`` (each frame to
      mean 128 / std 48) is the one that survives an exposure change between the two frames (next frame
      darkened to 70 %: raw LK gives 0 valid points, ``"frame"`` 399 at 0.88 %), but costs 8-20 % of the
      valid points without one and breaks when the view's content changes (sky replacing ground as the camera
      pitches: 12 of 901 points tracked at 5° pitch per frame). ``"pair"`` (both frames mapped with the previous
      frame's map) keeps brightness constancy and gives dark scenes their contrast back (ICL-NUIM lit at 25 %:
      several times the raw valid points), and on ICL-NUIM it gives 483 valid per pair against 458 raw (median
      over pairs, same accuracy). In the FlowNav scene, though, the unlit sky dominates the frame's standard
      deviation, so normalising lowers the capsules' contrast: median valid points per frame 16 (``"pair"``)
      against 28.5 (``"off"``) at daylight and no real gain in the dark, hence ``"off"`` by default.
    * ``min_parallax_px=1.0``: measured per-point depth error × parallax is about 0.1-0.15 px (median) and
      0.5 px (90th percentile), i.e. at 1 px parallax about 13 % median / 50 % p90 error, fine for the
      metre-wide bins of :func:`estimator.sector_histogram`. ICL-NUIM's pairs all have more than 4 px, so
      the threshold there only matters for hovering and near the focus of expansion.
    * ``max_epipolar_error_px=1.0``: removes 3-9 % of the points (mistracks) and improves the median from
      0.90 / 0.55 % (off) to 0.86 / 0.52 %; 0.5 px gives 0.82 / 0.47 % with 8-16 % fewer points. With
      exact motion. When the motion is known only approximately, the derotation error (about
      ``f · rotation error`` pixels, 9 px per degree at f = 525) also moves points off the line: raise this
      threshold accordingly or nearly every point is rejected.

    Args:
        intrinsics: Camera intrinsics; images must be ``intrinsics.width`` × ``intrinsics.height``.
        method: ``"triangulation"`` (least squares over both flow components, default) or ``"thesis"``
            (Euler-angle derotation and per-point larger-component depth, thesis eqs. 4.12/4.15/4.18,
            Fig. 24).
            See :func:`estimator.geometry.solve_depth`.
        fast_threshold: FAST intensity threshold in grey levels, an integer in [1, 255]. Lower finds more,
            weaker corners.
        max_points: Most keypoints kept per frame (strongest first, see ``spread_keypoints``), an integer
            >= 1, or None for every FAST corner. Bounds the time per frame.
        win_size: LK window side in pixels, an integer in [3, 101] (thesis: 10).
        max_level: Highest LK pyramid level, an integer in [0, 8] (thesis: 3; 0 = no pyramid).
        max_lk_error: Largest accepted LK error (mean absolute intensity difference over the window, grey
            levels), > 0 (thesis: 5).
        spread_keypoints: When more than ``max_points`` corners are found, balance the kept ones over a
            ``spread_grid`` of cells instead of taking the strongest overall (which crowd onto textured
            objects, as the thesis observed).
        spread_grid: ``(rows, cols)`` of the spreading grid, each an integer in [1, 64].
        forward_backward: Track every point back from the next into the previous frame and reject points
            that do not return to within ``fb_max_error_px``.
        fb_max_error_px: Largest accepted forward-backward error in pixels, > 0.
        normalize_brightness: Contrast normalisation before FAST and LK (thesis §5.2.3 suggests it; off by
            default, see above): ``"pair"`` (``True`` means the same) maps both frames of a pair with the affine map that
            takes the previous frame to mean 128 and standard deviation 48: dark or low-contrast scenes get
            their contrast back (``fast_threshold`` is then relative to a normalised contrast) while the two
            frames stay brightness-constant for LK even when the view's content changes (sky replacing
            ground as the drone pitches). ``"frame"`` normalises each frame on its own, which also undoes a
            global exposure change between the two frames but breaks brightness constancy when the content
            changes. ``"off"`` (``False``; default) tracks and detects on the raw frames.
        min_parallax_px: Smallest translational flow in pixels for a depth to be valid, >= 0. Points near
            the focus of expansion, when hovering or without translation have no parallax and no depth.
        max_epipolar_error_px: Largest distance in pixels of the tracked point from the line the known motion
            allows (the epipolar line through the derotated position), > 0. A static point can only be off
            that line by flow noise plus the motion error; mistracks (repeated texture, occlusion edges) and
            moving objects usually are off by more.
        baseline_frames: Longest baseline of a streamed depth, in frames, an integer in [1, 16]. 1 (default)
            ranges every point over one frame pair, as the thesis. Above 1, :meth:`update` follows the same
            FAST corners from frame to frame and ranges each from its oldest view within that many frames,
            with the told motions composed, or from the previous frame where that fails a check
            (:mod:`estimator.multiframe`): far points and points near the focus of expansion gain parallax,
            while motion errors add up over the frames (``results/depth_yield.md``). :meth:`estimate` always
            uses the one pair it is given.

    Raises:
        ValueError: A parameter is out of range; the message names it, its value and the allowed range.
    """

    def __init__(
        self,
        intrinsics: CameraIntrinsics,
        *,
        method: str = "triangulation",
        fast_threshold: int = 20,
        max_points: int | None = 1000,
        win_size: int = 10,
        max_level: int = 3,
        max_lk_error: float = 5.0,
        spread_keypoints: bool = True,
        spread_grid: tuple[int, int] = (6, 8),
        forward_backward: bool = True,
        fb_max_error_px: float = 0.5,
        fb_max_level: int | None = 0,
        normalize_brightness: bool | str = "off",
        min_parallax_px: float = 1.0,
        max_epipolar_error_px: float = 1.0,
        baseline_frames: int = 1,
    ) -> None:
        if not isinstance(intrinsics, CameraIntrinsics):
            raise ValueError(f"intrinsics must be a CameraIntrinsics, got {type(intrinsics).__name__}")
        if method not in geometry.METHODS:
            raise ValueError(f"method must be one of {geometry.METHODS}, got {method!r}")
        self.intrinsics = intrinsics
        self.method = method
        self.fast_threshold = require_int_in_range("fast_threshold", fast_threshold, 1, 255)
        self.max_points = None if max_points is None else require_int_in_range("max_points", max_points, 1)
        self.win_size = require_int_in_range("win_size", win_size, 3, 101)
        self.max_level = require_int_in_range("max_level", max_level, 0, 8)
        self.max_lk_error = require_positive_finite("max_lk_error", max_lk_error)
        self.spread_keypoints = require_bool("spread_keypoints", spread_keypoints)
        self.spread_grid = as_grid("spread_grid", spread_grid)
        self.forward_backward = require_bool("forward_backward", forward_backward)
        self.fb_max_error_px = require_positive_finite("fb_max_error_px", fb_max_error_px)
        self.fb_max_level = (
            None if fb_max_level is None else require_int_in_range("fb_max_level", fb_max_level, 0, 8)
        )
        if isinstance(normalize_brightness, (bool, np.bool_)):
            normalize_brightness = "pair" if normalize_brightness else "off"
        if normalize_brightness not in tracking.BRIGHTNESS_MODES:
            raise ValueError(
                "normalize_brightness must be one of 'pair', 'frame', 'off' (or True/False), "
                f"got {normalize_brightness!r}"
            )
        self.normalize_brightness = normalize_brightness
        self.min_parallax_px = require_non_negative_finite("min_parallax_px", min_parallax_px)
        self.max_epipolar_error_px = require_positive_finite("max_epipolar_error_px", max_epipolar_error_px)
        self.baseline_frames = require_int_in_range("baseline_frames", baseline_frames, 1, 16)
        self._window = multiframe.TrackWindow(self.baseline_frames) if self.baseline_frames > 1 else None
        self._detector = cv2.FastFeatureDetector.create(self.fast_threshold, True)
        self._previous: tracking.PreparedFrame | None = None

    def estimate(
        self, prev_image: np.ndarray, next_image: np.ndarray, rotation: ArrayLike, translation: ArrayLike
    ) -> DepthPoints:
        """Depth of the previous frame's keypoints from one frame pair.

        Args:
            prev_image: Previous frame, uint8 (H, W) or (H, W, 3) RGB, of the intrinsics' size.
            next_image: Next frame, same size.
            rotation: (3, 3) rotation matrix from the previous to the next camera frame.
            translation: (3,) translation in metres, ``X_next = R @ X_prev + t``.

        Returns:
            :class:`DepthPoints` for the keypoints of ``prev_image``.

        Raises:
            ValueError: An image is not uint8 (H, W) or (H, W, 3), the images differ in size or do not match
                the intrinsics, ``rotation`` is not a rotation matrix, or the motion is not finite.
        """
        start = time.perf_counter()
        rotation, translation = self._check_motion(rotation, translation)
        prev_gray = tracking.to_grayscale(prev_image, "prev_image")
        next_gray = tracking.to_grayscale(next_image, "next_image")
        if prev_gray.shape != next_gray.shape:
            raise ValueError(
                "prev_image and next_image must have the same size, got "
                f"{prev_gray.shape[1]}x{prev_gray.shape[0]} and {next_gray.shape[1]}x{next_gray.shape[0]}"
            )
        self._check_size(prev_gray, "prev_image")
        timings = dict.fromkeys(TIMING_KEYS, 0.0)
        previous = self._prepare(prev_gray, timings)
        current = self._prepare(next_gray, timings)
        return self._estimate_pair(previous, current, rotation, translation, timings, start)

    def update(self, image: np.ndarray, rotation: ArrayLike, translation: ArrayLike) -> DepthPoints:
        """Streaming estimation: depth of the previous frame's keypoints, then remember this frame.

        The frame is converted and normalised once and kept as the previous frame of the next call (see
        :mod:`estimator.tracking` for why LK's image pyramids cannot be kept too).

        Args:
            image: The new frame, uint8 (H, W) or (H, W, 3) RGB, of the intrinsics' size.
            rotation: (3, 3) rotation from the previous frame's camera to this one's (ignored, but checked,
                on the first call).
            translation: (3,) translation in metres from the previous frame to this one,
                ``X_this = R @ X_previous + t``.

        Returns:
            :class:`DepthPoints` for the previous frame's keypoints; empty on the first call after
            construction or :meth:`reset`.

        Raises:
            ValueError: As :meth:`estimate`.
        """
        start = time.perf_counter()
        rotation, translation = self._check_motion(rotation, translation)
        gray = tracking.to_grayscale(image, "image")
        self._check_size(gray, "image")
        timings = dict.fromkeys(TIMING_KEYS, 0.0)
        current = self._prepare(gray, timings)
        previous, self._previous = self._previous, current
        if previous is None:
            timings["total"] = time.perf_counter() - start
            return DepthPoints.empty(timings)
        return self._estimate_pair(previous, current, rotation, translation, timings, start)

    def reset(self) -> None:
        """Forget the previous frame (and the tracks): the next :meth:`update` starts a new stream and returns
        empty."""
        self._previous = None
        if self._window is not None:
            self._window.reset()

    def _estimate_pair(
        self,
        previous: tracking.PreparedFrame,
        current: tracking.PreparedFrame,
        rotation: np.ndarray,
        translation: np.ndarray,
        timings: dict[str, float],
        start: float,
    ) -> DepthPoints:
        stage_start = time.perf_counter()
        prev_image, next_image = tracking.tracking_images(previous, current, self.normalize_brightness)
        timings["prepare"] += time.perf_counter() - stage_start
        stage_start = time.perf_counter()
        points = self._keypoints(prev_image)
        timings["fast"] = time.perf_counter() - stage_start
        if len(points) == 0:
            if self._window is not None:  # the step is still part of the window's motion history
                self._window.advance(points, np.zeros(0, bool), (rotation, translation))
            timings["total"] = time.perf_counter() - start
            return DepthPoints.empty(timings)

        stage_start = time.perf_counter()
        tracks = self._track(prev_image, next_image, points)
        timings["flow"] = time.perf_counter() - stage_start

        stage_start = time.perf_counter()
        tracked = self._tracking_ok(tracks)
        previous_normalized = self.intrinsics.normalize(points)
        next_normalized = self.intrinsics.normalize(tracks.next_points)
        baseline = None
        window = self._window
        if window is None:
            solution = geometry.solve_depth(
                previous_normalized,
                next_normalized,
                rotation,
                translation,
                self.intrinsics.focal_scale,
                self.method,
            )
            depth, parallax = solution.depth, solution.parallax_px
            geometry_ok = geometry.valid_depth_mask(
                solution, self.min_parallax_px, self.max_epipolar_error_px
            )
        else:
            ranging = self._range_tracks(
                window, previous_normalized, next_normalized, tracks, tracked, rotation, translation
            )
            depth, parallax, geometry_ok, baseline = (
                ranging.depth,
                ranging.parallax_px,
                ranging.ok,
                ranging.baseline,
            )
        timings["depth"] = time.perf_counter() - stage_start
        timings["total"] = time.perf_counter() - start
        return DepthPoints(
            points=points,
            next_points=tracks.next_points,
            depth=depth,
            valid=tracked & geometry_ok,
            tracked=tracked,
            parallax_px=parallax,
            timings=timings,
            baseline_frames=baseline,
        )

    def _keypoints(self, prev_image: np.ndarray) -> np.ndarray:
        """FAST corners of the previous frame; with a track window, they become its tracks, a corner that
        continues a track at that track's position."""
        spread_grid = self.spread_grid if self.spread_keypoints else None
        points = tracking.detect_keypoints(prev_image, self._detector, self.max_points, spread_grid)
        if self._window is None:
            return points
        self._window.adopt(points)
        return self._window.latest_points.copy()

    def _range_tracks(
        self,
        window: multiframe.TrackWindow,
        previous_normalized: np.ndarray,
        next_normalized: np.ndarray,
        tracks: tracking.Tracks,
        tracked: np.ndarray,
        rotation: np.ndarray,
        translation: np.ndarray,
    ) -> multiframe.Ranging:
        """Depths over the window's baselines; then the window moves on to the next frame."""
        anchors, frames_back = window.anchors()
        ranging = multiframe.range_over_baselines(
            self.intrinsics.normalize(anchors),
            previous_normalized,
            next_normalized,
            frames_back + 1,
            multiframe.motions_to_latest(window.steps, self.baseline_frames),
            (rotation, translation),
            self.intrinsics.focal_scale,
            self.method,
            self.min_parallax_px,
            self.max_epipolar_error_px,
        )
        keep = tracked & ~ranging.off_epipolar
        window.advance(tracks.next_points, keep, (rotation, translation), restart=ranging.drifted)
        return ranging

    def _track(self, prev_image: np.ndarray, next_image: np.ndarray, points: np.ndarray) -> tracking.Tracks:
        return tracking.track_points(
            prev_image,
            next_image,
            points,
            self.win_size,
            self.max_level,
            self.forward_backward,
            self.fb_max_level,
        )

    def _tracking_ok(self, tracks: tracking.Tracks) -> np.ndarray:
        ok = tracks.status & (tracks.lk_error <= self.max_lk_error)
        if self.forward_backward:
            ok &= tracks.fb_error_px <= self.fb_max_error_px
        return ok

    def _prepare(self, gray: np.ndarray, timings: dict[str, float]) -> tracking.PreparedFrame:
        stage_start = time.perf_counter()
        frame_map = tracking.brightness_map(gray) if self.normalize_brightness != "off" else (1.0, 0.0)
        timings["prepare"] += time.perf_counter() - stage_start
        return tracking.PreparedFrame(gray=gray, brightness_map=frame_map)

    def _check_size(self, gray: np.ndarray, name: str) -> None:
        height, width = gray.shape
        if (width, height) != self.intrinsics.image_size:
            raise ValueError(
                f"{name} must be {self.intrinsics.width}x{self.intrinsics.height} (width x height) to match "
                f"the camera intrinsics, got {width}x{height}"
            )

    @staticmethod
    def _check_motion(rotation: ArrayLike, translation: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        return as_rotation_matrix("rotation", rotation), as_translation_vector("translation", translation)
