"""Tests of estimator.tracking: image checks, brightness normalisation, keypoint selection, LK accuracy."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from helpers import TESTDATA

from estimator import tracking

RUBBERWHALE = TESTDATA / "middlebury_rubberwhale"
_UNKNOWN_FLOW = 1e9  # Middlebury marks unknown flow with |value| > 1e9


def _read_flo(path: Path) -> np.ndarray:
    with path.open("rb") as stream:
        magic = np.fromfile(stream, np.float32, 1)[0]
        assert magic == np.float32(202021.25), "not a Middlebury .flo file"  # test data sanity, not input
        width, height = np.fromfile(stream, np.int32, 2)
        return np.fromfile(stream, np.float32, int(width) * int(height) * 2).reshape(height, width, 2)


def _textured_image(seed: int = 0, size: tuple[int, int] = (480, 640)) -> np.ndarray:
    rng = np.random.default_rng(seed)
    noise = rng.integers(0, 256, size=(size[0] // 8, size[1] // 8), dtype=np.uint8)
    return cv2.resize(noise, (size[1], size[0]), interpolation=cv2.INTER_CUBIC)


# None: the backward check repeats the forward search; 0: it starts at the forward track's origin on the
# full-resolution level only (the estimator's default since the throughput work), which must not let more mistracks through.
@pytest.mark.parametrize("backward_max_level", [None, 0])
def test_rubberwhale_lk_endpoint_error(backward_max_level):
    if not RUBBERWHALE.is_dir():
        pytest.skip(f"third-party test data not found at {RUBBERWHALE}")
    first = cv2.imread(str(RUBBERWHALE / "RubberWhale1.png"), cv2.IMREAD_GRAYSCALE)
    second = cv2.imread(str(RUBBERWHALE / "RubberWhale2.png"), cv2.IMREAD_GRAYSCALE)
    true_flow = _read_flo(RUBBERWHALE / "RubberWhale.flo")
    # The estimator's defaults: FAST 20, 1000 points spread on a 6x8 grid, LK 10x10 / level 3, normalised
    # brightness, forward-backward 0.5 px, LK error <= 5.
    detector = cv2.FastFeatureDetector_create(20, True)
    points = tracking.detect_keypoints(first, detector, 1000, (6, 8))
    tracks = tracking.track_points(
        tracking.normalize_brightness(first),
        tracking.normalize_brightness(second),
        points,
        10,
        3,
        True,
        backward_max_level,
    )
    tracked = tracks.status & (tracks.lk_error <= 5.0) & (tracks.fb_error_px <= 0.5)
    pixel = points.astype(np.intp)
    point_flow = true_flow[pixel[:, 1], pixel[:, 0]]
    known = np.all(np.abs(point_flow) < _UNKNOWN_FLOW, axis=1)
    used = tracked & known
    endpoint_error = np.linalg.norm(tracks.next_points[used] - points[used] - point_flow[used], axis=1)
    assert used.sum() >= 500
    assert np.median(endpoint_error) <= 0.15


def test_to_grayscale_accepts_gray_and_rgb():
    gray = _textured_image()[:48, :64]
    np.testing.assert_array_equal(tracking.to_grayscale(gray, "image"), gray)
    rgb = np.repeat(gray[:, :, None], 3, axis=2)
    np.testing.assert_array_equal(tracking.to_grayscale(rgb, "image", (64, 48)), gray)


@pytest.mark.parametrize(
    ("image", "message"),
    [
        ([[0, 1], [2, 3]], r"frame must be a numpy uint8 array of shape \(H, W\) or \(H, W, 3\), got list"),
        (np.zeros((48, 64), np.float32), r"frame must have dtype uint8, got float32"),
        (np.zeros((48, 64, 4), np.uint8), r"frame must have shape \(H, W\) or \(H, W, 3\), got \(48, 64, 4"),
        (np.zeros((48,), np.uint8), r"frame must have shape \(H, W\) or \(H, W, 3\)"),
        (np.zeros((0, 64), np.uint8), r"frame must not be empty"),
        (np.zeros((64, 48), np.uint8), r"frame must be 64x48 \(width x height\) .* got 48x64"),
    ],
)
def test_to_grayscale_rejects_bad_images(image, message):
    with pytest.raises(ValueError, match=message):
        tracking.to_grayscale(image, "frame", (64, 48))


def test_normalize_brightness_undoes_gain_and_offset():
    gray = _textured_image()
    reference = tracking.normalize_brightness(gray).astype(np.float64)
    darker = cv2.convertScaleAbs(gray, alpha=0.6, beta=20.0)
    changed = tracking.normalize_brightness(darker).astype(np.float64)
    # Only quantisation of the darker image remains.
    assert np.abs(changed - reference).mean() < 1.5
    mean, std = cv2.meanStdDev(tracking.normalize_brightness(gray))
    assert mean[0, 0] == pytest.approx(128.0, abs=2.0)
    assert std[0, 0] == pytest.approx(48.0, abs=2.0)


def test_normalize_brightness_leaves_flat_images_flat():
    flat = np.full((10, 10), 200, np.uint8)
    np.testing.assert_array_equal(tracking.normalize_brightness(flat), np.full((10, 10), 128, np.uint8))


def test_detect_keypoints_limits_count_and_returns_pixel_positions():
    gray = _textured_image()
    detector = cv2.FastFeatureDetector_create(10, True)
    everything = tracking.detect_keypoints(gray, detector, None, None)
    assert len(everything) > 300
    assert everything.dtype == np.float32
    strongest = tracking.detect_keypoints(gray, detector, 300, None)
    spread = tracking.detect_keypoints(gray, detector, 300, (6, 8))
    assert len(strongest) == len(spread) == 300
    np.testing.assert_array_equal(spread, np.rint(spread))


def test_spreading_balances_a_crowded_image():
    # Strong texture in the top-left quarter, faint texture elsewhere: the strongest-first selection stays
    # in the strong quarter, the spread one covers the rest of the image too.
    faint = cv2.convertScaleAbs(_textured_image(2), alpha=0.25, beta=96.0)
    gray = faint.copy()
    gray[:240, :320] = _textured_image(1, (240, 320))
    detector = cv2.FastFeatureDetector_create(10, True)
    strongest = tracking.detect_keypoints(gray, detector, 200, None)
    spread = tracking.detect_keypoints(gray, detector, 200, (4, 4))
    outside_texture = (spread[:, 0] >= 320) | (spread[:, 1] >= 240)
    assert len(spread) == 200
    assert outside_texture.sum() >= 50
    assert outside_texture.sum() > 2 * ((strongest[:, 0] >= 320) | (strongest[:, 1] >= 240)).sum()


def test_no_corners_gives_no_points():
    detector = cv2.FastFeatureDetector_create(20, True)
    points = tracking.detect_keypoints(np.full((48, 64), 7, np.uint8), detector, 100, (2, 2))
    assert points.shape == (0, 2)
    blank = np.zeros((48, 64), np.uint8)
    tracks = tracking.track_points(blank, blank, points, 10, 3, True)
    assert tracks.next_points.shape == (0, 2)


def test_track_points_follows_a_known_shift():
    gray = _textured_image()
    shifted = np.roll(gray, shift=(2, 3), axis=(0, 1))
    detector = cv2.FastFeatureDetector_create(20, True)
    points = tracking.detect_keypoints(gray, detector, 300, (6, 8))
    points = points[(points[:, 0] > 20) & (points[:, 1] > 20)]
    for backward_max_level in (None, 0):
        tracks = tracking.track_points(gray, shifted, points, 10, 3, True, backward_max_level)
        ok = tracks.status & (tracks.fb_error_px < 0.5)
        assert ok.mean() > 0.9
    ok = tracks.status & (tracks.fb_error_px < 0.5)
    assert ok.mean() > 0.9
    np.testing.assert_allclose(np.median(tracks.next_points[ok] - points[ok], axis=0), [3.0, 2.0], atol=0.05)
