"""Tests of estimator.histogram.sector_histogram: normalisation, binning, sectors and input checks."""

from __future__ import annotations

import numpy as np
import pytest

from estimator import DEFAULT_BIN_EDGES, sector_counts, sector_fraction, sector_histogram, sector_near_depth

IMAGE_SIZE = (640, 480)


def _random_points(count: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    points = rng.uniform([0.0, 0.0], [639.0, 479.0], size=(count, 2)).astype(np.float32)
    depth = rng.uniform(0.2, 20.0, size=count)
    valid = rng.random(count) < 0.8
    return points, depth, valid


def test_shape_dtype_and_default_bins():
    points, depth, valid = _random_points(500)
    histogram = sector_histogram(points, depth, valid, IMAGE_SIZE, sectors=(2, 4))
    assert histogram.shape == (2, 4, len(DEFAULT_BIN_EDGES) - 1)
    assert histogram.dtype == np.float32


def test_non_empty_sectors_sum_to_one_and_empty_sectors_are_zero():
    # Points only in the left half: the right sectors stay empty.
    points = np.array([[10.0, 10.0], [100.0, 400.0], [200.0, 200.0], [300.0, 50.0]], dtype=np.float32)
    depth = np.array([0.5, 1.5, 4.0, 20.0])
    histogram = sector_histogram(points, depth, np.ones(4, dtype=bool), IMAGE_SIZE, sectors=(1, 2))
    np.testing.assert_allclose(histogram[0, 0].sum(), 1.0)
    np.testing.assert_array_equal(histogram[0, 1], 0.0)
    # 0.5 m → [0, 1); 1.5 m → [1, 2); 4 m → [3, 5); 20 m → beyond the last edge → the open far bin.
    np.testing.assert_allclose(histogram[0, 0], [0.25, 0.25, 0.0, 0.25, 0.0, 0.25])


def test_matches_a_per_point_reference():
    points, depth, valid = _random_points(2000, seed=3)
    edges = (0.0, 2.0, 4.0, 8.0)
    sectors = (3, 5)
    histogram = sector_histogram(points, depth, valid, IMAGE_SIZE, sectors=sectors, bin_edges=edges)
    expected = np.zeros((3, 5, 3))
    for (u, v), d, ok in zip(points, depth, valid, strict=True):
        if not ok:
            continue
        row = int((v + 0.5) * 3 / 480)
        col = int((u + 0.5) * 5 / 640)
        expected[row, col, min(int(np.searchsorted(edges, d, side="right")) - 1, 2)] += 1
    expected /= np.maximum(expected.sum(axis=2, keepdims=True), 1)
    np.testing.assert_allclose(histogram, expected, atol=1e-6)


def test_depth_below_first_edge_goes_to_first_bin_and_invalid_points_are_ignored():
    points = np.array([[5.0, 5.0], [6.0, 6.0]], dtype=np.float32)
    histogram = sector_histogram(
        points, np.array([0.1, np.nan]), np.array([True, False]), IMAGE_SIZE, (1, 1), (0.5, 1.0, 2.0)
    )
    np.testing.assert_array_equal(histogram[0, 0], [1.0, 0.0])


def test_sector_boundaries_follow_the_pixel_centre_convention():
    # With 2 columns over 640 px the boundary is at u = 319.5: pixel 319 is left, pixel 320 right.
    points = np.array([[319.0, 0.0], [320.0, 0.0]], dtype=np.float32)
    histogram = sector_histogram(points, np.array([1.0, 1.0]), np.ones(2, bool), IMAGE_SIZE, (1, 2))
    assert histogram[0, 0].sum() == 1.0
    assert histogram[0, 1].sum() == 1.0


def test_points_outside_the_image_are_ignored():
    points = np.array([[-5.0, 10.0], [700.0, 10.0], [10.0, 480.0]], dtype=np.float32)
    histogram = sector_histogram(points, np.ones(3), np.ones(3, bool), IMAGE_SIZE, (2, 2))
    np.testing.assert_array_equal(histogram, 0.0)


def test_no_points_gives_all_zeros():
    histogram = sector_histogram(np.empty((0, 2)), np.empty(0), np.empty(0, bool), IMAGE_SIZE)
    assert histogram.shape == (3, 3, 6)
    np.testing.assert_array_equal(histogram, 0.0)


def test_count_of_points_does_not_change_a_distribution():
    points, depth, valid = _random_points(300, seed=5)
    once = sector_histogram(points, depth, valid, IMAGE_SIZE, (2, 2))
    twice = sector_histogram(
        np.concatenate([points, points]),
        np.concatenate([depth, depth]),
        np.concatenate([valid, valid]),
        IMAGE_SIZE,
        (2, 2),
    )
    np.testing.assert_allclose(once, twice, atol=1e-7)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"points": np.zeros((3, 3))}, r"points must be a numeric \(N, 2\) array"),
        ({"depth": np.zeros((3, 1))}, r"depth must be a numeric \(N,\) array"),
        ({"valid": np.ones(3, dtype=np.int64)}, r"valid must be a bool \(N,\) array"),
        ({"depth": np.zeros(2)}, r"points, depth and valid must have the same length N, got 3, 2 and 3"),
        ({"depth": np.array([1.0, np.inf, 1.0])}, r"depth must be finite where valid is True"),
        ({"points": np.array([[0.0, 0.0], [np.nan, 1.0], [2.0, 2.0]])}, r"points must be finite where valid"),
        ({"image_size": (640,)}, r"image_size must be a pair of positive integers \(width, height\)"),
        ({"image_size": (640, 0)}, r"image_size\[1\] must be an integer with 1 <= image_size\[1\]"),
        ({"sectors": (0, 3)}, r"sectors\[0\] must be an integer with 1 <= sectors\[0\]"),
        ({"sectors": 3}, r"sectors must be a pair of positive integers \(rows, cols\)"),
        ({"bin_edges": (1.0,)}, r"bin_edges must be a 1-D sequence of at least 2 edges"),
        ({"bin_edges": (0.0, 2.0, 1.0)}, r"bin_edges must be strictly increasing"),
        ({"bin_edges": (0.0, np.inf)}, r"bin_edges must be finite"),
        ({"bin_edges": "near,far"}, r"bin_edges must be a sequence of numbers"),
    ],
)
def test_bad_input_raises_value_error_naming_the_argument(kwargs, message):
    arguments = {
        "points": np.zeros((3, 2)),
        "depth": np.ones(3),
        "valid": np.ones(3, dtype=bool),
        "image_size": IMAGE_SIZE,
        "sectors": (2, 2),
        "bin_edges": DEFAULT_BIN_EDGES,
    }
    arguments.update(kwargs)
    with pytest.raises(ValueError, match=message):
        sector_histogram(**arguments)


def test_sector_fraction_counts_selected_among_the_points_of_each_sector():
    points = np.array([[1.0, 1.0], [2.0, 2.0], [3.0, 1.0], [15.0, 1.0], [15.0, 9.0], [50.0, 5.0]])
    among = np.array([True, True, True, True, False, True])  # the last one is outside the 20x10 image
    selected = np.array([True, False, False, True, True, True])
    fraction = sector_fraction(points, selected, among, (20, 10), sectors=(2, 2))
    assert fraction.dtype == np.float32 and fraction.shape == (2, 2)
    # top left: 1 of 3; top right: 1 of 1; bottom right: its only point is not among; bottom left: empty
    np.testing.assert_allclose(fraction, [[1 / 3, 1.0], [0.0, 0.0]])


@pytest.mark.parametrize(
    ("selected", "among", "message"),
    [
        (np.ones(2, bool), np.ones(3, bool), r"selected must be a bool \(N,\) array like among"),
        (np.ones(3), np.ones(3, bool), "selected must be a bool"),
        (np.ones(3, bool), np.ones(3), r"among must be a bool \(N,\) array"),
        (np.ones(3, bool), np.ones(2, bool), "points and among must have the same length N, got 3 and 2"),
    ],
)
def test_sector_fraction_bad_input_names_the_argument(selected, among, message):
    with pytest.raises(ValueError, match=message):
        sector_fraction(np.zeros((3, 2)), selected, among, (20, 10))


def test_sector_counts_count_the_masked_points_per_sector() -> None:
    points, _, valid = _random_points(500, seed=4)
    counts = sector_counts(points, valid, IMAGE_SIZE, sectors=(3, 5))
    assert counts.shape == (3, 5) and counts.dtype == np.float32 and counts.sum() == valid.sum()
    column = np.minimum(((points[:, 0] + 0.5) * 5 / 640).astype(int), 4)
    row = np.minimum(((points[:, 1] + 0.5) * 3 / 480).astype(int), 2)
    expected = np.zeros((3, 5))
    np.add.at(expected, (row[valid], column[valid]), 1)
    np.testing.assert_array_equal(counts, expected)
    with pytest.raises(ValueError, match="counted"):
        sector_counts(points, valid[:10], IMAGE_SIZE)


def test_sector_near_depth_is_a_low_quantile_per_sector_against_a_loop() -> None:
    points, depth, valid = _random_points(600, seed=5)
    near = sector_near_depth(points, depth, valid, IMAGE_SIZE, sectors=(3, 5), quantile=0.2)
    assert near.shape == (3, 5) and near.dtype == np.float32
    column = np.minimum(((points[:, 0] + 0.5) * 5 / 640).astype(int), 4)
    row = np.minimum(((points[:, 1] + 0.5) * 3 / 480).astype(int), 2)
    for r in range(3):
        for c in range(5):
            ranked = np.sort(depth[valid & (row == r) & (column == c)])
            expected = (
                ranked[max(int(0.2 * (len(ranked) - 1)), min(1, len(ranked) - 1))] if len(ranked) else np.inf
            )
            assert near[r, c] == pytest.approx(expected, rel=1e-6)


def test_one_stray_near_depth_does_not_set_a_sectors_near_depth() -> None:
    points = np.array([[10.0, 10.0], [20.0, 20.0], [30.0, 30.0], [600.0, 400.0]])
    depth = np.array([0.1, 4.0, 5.0, 2.0])  # 0.1 m is a stray depth among 4-5 m
    near = sector_near_depth(points, depth, np.ones(4, bool), IMAGE_SIZE, sectors=(2, 2), quantile=0.0)
    np.testing.assert_array_equal(near, [[4.0, np.inf], [np.inf, 2.0]])  # a lone point still counts


@pytest.mark.parametrize("quantile", [-0.1, 1.5, float("nan"), True, "0.1"])
def test_sector_near_depth_rejects_a_quantile_outside_zero_to_one(quantile) -> None:
    points, depth, valid = _random_points(10)
    with pytest.raises(ValueError, match=r"quantile must be a number in \[0, 1\], got"):
        sector_near_depth(points, depth, valid, IMAGE_SIZE, quantile=quantile)


def test_a_sector_grid_gives_the_functions_results_from_one_located_frame() -> None:
    # The env checks its grid once and locates each frame's points once for every product.
    from estimator.histogram import SectorGrid

    points, depth, valid = _random_points(400, seed=3)
    points[::7] = [-5.0, 700.0]  # outside the image
    points[~valid] = np.nan  # an untracked point may have no position at all
    depth[~valid] = np.nan
    selected = np.random.default_rng(4).random(400) < 0.5
    grid = SectorGrid(IMAGE_SIZE, (3, 4), (0.0, 2.0, 5.0, 11.0))
    sector = grid.locate(points)
    assert np.all(sector[~valid] == -1) and np.all(sector[::7] == -1)
    np.testing.assert_array_equal(
        grid.histogram(sector, depth, valid),
        sector_histogram(points, depth, valid, IMAGE_SIZE, (3, 4), (0.0, 2.0, 5.0, 11.0)),
    )
    np.testing.assert_array_equal(
        grid.fraction(sector, selected, valid), sector_fraction(points, selected, valid, IMAGE_SIZE, (3, 4))
    )
    np.testing.assert_array_equal(
        grid.counts(sector, valid), sector_counts(points, valid, IMAGE_SIZE, (3, 4))
    )
    np.testing.assert_array_equal(
        grid.near_depth(sector, depth, valid, 0.2),
        sector_near_depth(points, depth, valid, IMAGE_SIZE, (3, 4), 0.2),
    )
    assert grid.shape == (3, 4, 3) and not grid.bin_edges.flags.writeable
    with pytest.raises(ValueError, match=r"^bin_edges must be strictly increasing, got \[0.0, 2.0, 1.0\]$"):
        SectorGrid(IMAGE_SIZE, (3, 4), (0.0, 2.0, 1.0))
