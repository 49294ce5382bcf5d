"""Which capsules the camera sees and where the histogram puts them, on hand-made capsules: occlusion, range,
the field of view's edges, and the sector and bin a front point falls in."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from agents.policies.camera_view import column_rays, first_hits, resolved_capsules, seen_capsules
from estimator.camera import CameraIntrinsics

# A camera at the origin looking along world +x: OpenCV x (right) is world -y, y (down) is world -z.
LOOKING_ALONG_X = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
# The env's camera: 160 x 120 px with a 60° vertical field of view.
INTRINSICS = CameraIntrinsics.from_fov(160, 120, 60.0)
RAYS = column_rays(LOOKING_ALONG_X, INTRINSICS.fx, INTRINSICS.cx, INTRINSICS.width)
# The bearing (rad, left positive) of the outermost pixel columns' centres.
EDGE = math.atan2(INTRINSICS.cx, INTRINSICS.fx)
ORIGIN = np.zeros(2)


def _at(bearing_deg: float, distance: float, radius: float) -> list[float]:
    """A capsule whose axis lies ``distance`` from the origin at ``bearing_deg`` (left of +x positive)."""
    bearing = math.radians(bearing_deg)
    return [distance * math.cos(bearing), distance * math.sin(bearing), radius]


def test_one_ray_per_column_spans_the_horizontal_field_of_view() -> None:
    assert RAYS.shape == (160, 2)
    np.testing.assert_allclose(np.linalg.norm(RAYS, axis=1), 1.0)
    bearings = np.degrees(np.arctan2(RAYS[:, 1], RAYS[:, 0]))
    # Column 0 (the image's left) looks left; the horizontal view is about 75° at 160 x 120 px.
    assert bearings[0] == pytest.approx(math.degrees(EDGE)) and bearings[-1] == pytest.approx(-bearings[0])
    assert 74.0 < bearings[0] - bearings[-1] < 76.0
    assert np.all(np.diff(bearings) < 0.0)


def test_a_nearer_capsule_hides_one_behind_it_but_not_one_that_peeks_out() -> None:
    front, hidden, peeking = [1.5, 0.0, 0.3], [3.0, 0.0, 0.3], [3.0, 0.6, 0.3]
    capsules = np.array([front, hidden, peeking])
    np.testing.assert_array_equal(seen_capsules(ORIGIN, RAYS, capsules, 5.0), [True, False, True])
    rows, distance = first_hits(ORIGIN, RAYS, capsules, 5.0)
    middle = 80
    assert rows[middle] == 0 and distance[middle] == pytest.approx(1.2, abs=0.01)


def test_a_capsule_counts_only_where_its_surface_is_within_the_range() -> None:
    capsules = np.array([[2.4, 0.0, 0.5]])  # its nearest surface 1.9 m away
    assert seen_capsules(ORIGIN, RAYS, capsules, 2.0)[0]
    assert not seen_capsules(ORIGIN, RAYS, capsules, 1.8)[0]
    rows, distance = first_hits(ORIGIN, RAYS, capsules, 1.8)
    assert (rows == -1).all() and np.isinf(distance).all()


def test_the_edges_of_the_field_of_view() -> None:
    radius, distance = 0.1, 1.5
    half_width = math.degrees(math.asin(radius / distance))  # the capsule's angular half-width
    edge = math.degrees(EDGE)
    just_in = np.array(
        [_at(edge + half_width - 0.5, distance, radius), _at(-edge - half_width + 0.5, distance, radius)]
    )
    just_out = np.array(
        [_at(edge + half_width + 0.5, distance, radius), _at(-edge - half_width - 0.5, distance, radius)]
    )
    assert seen_capsules(ORIGIN, RAYS, just_in, 5.0).all()
    assert not seen_capsules(ORIGIN, RAYS, just_out, 5.0).any()
    behind = np.array([[-1.5, 0.0, 0.5]])
    assert not seen_capsules(ORIGIN, RAYS, behind, 5.0).any()


def test_from_inside_a_capsule_every_ray_hits_it_at_once() -> None:
    rows, distance = first_hits(ORIGIN, RAYS, np.array([[0.2, 0.0, 0.5], [1.5, 0.0, 0.3]]), 2.0)
    assert (rows == 0).all() and (distance == 0.0).all()
    rows, distance = first_hits(ORIGIN, RAYS, np.zeros((0, 3)), 2.0)
    assert rows.shape == (160,) and (rows == -1).all()


def _resolve(capsules: list[list[float]], columns: int = 5) -> tuple[np.ndarray, np.ndarray]:
    return resolved_capsules(
        np.array(capsules),
        np.array([0.0, 0.0, 1.0]),
        LOOKING_ALONG_X,
        INTRINSICS.fx,
        INTRINSICS.cx,
        INTRINSICS.width,
        columns,
        np.array([0.0, 1.0, 2.0, 3.0, 5.0, 8.0, 13.0]),
    )


def test_a_capsule_ahead_is_put_at_its_front_points_sector_and_bin_centres() -> None:
    # Its front point is 1.2 m ahead, in the bin [1, 2) m (centre 1.5 m) and the middle of 5 sector columns.
    resolved, whole = _resolve([[1.7, 0.0, 0.5]])
    np.testing.assert_allclose(resolved, [[2.0, 0.0, 0.5]], atol=1e-9)
    assert whole.tolist() == [True]
    # Far beyond the last edge: the last bin, whose centre is that of its edges.
    far, _ = _resolve([[20.5, 0.0, 0.5]])
    np.testing.assert_allclose(far[0, :2], [11.0, 0.0], atol=1e-9)


def test_a_capsule_off_the_axis_moves_to_its_sector_columns_centre() -> None:
    sector_width = 160 / 5
    # The sector left of the middle spans columns 31.5-63.5: its centre column 47.5 px.
    centre_bearing = math.atan2(INTRINSICS.cx - (1.5 * sector_width - 0.5), INTRINSICS.fx)
    resolved, whole = _resolve([_at(10.0, 1.5, 0.3)])
    assert whole.tolist() == [True]
    assert math.atan2(resolved[0, 1], resolved[0, 0]) == pytest.approx(centre_bearing)


def test_a_front_point_beyond_the_images_edge_lands_in_the_edge_sector() -> None:
    # Left of the view's edge, with part of its surface inside the view.
    resolved, whole = _resolve([_at(math.degrees(EDGE) + 3.0, 1.2, 0.5)])
    assert whole.tolist() == [False]
    edge_sector_bearing = math.atan2(INTRINSICS.cx - (0.5 * 160 / 5 - 0.5), INTRINSICS.fx)
    assert math.atan2(resolved[0, 1], resolved[0, 0]) == pytest.approx(edge_sector_bearing)
    # Right of the view: the rightmost sector; beside the camera (no depth ahead): the first bin and the edge.
    right, whole = _resolve([_at(-80.0, 0.8, 0.5)])
    assert whole.tolist() == [False] and math.atan2(right[0, 1], right[0, 0]) == pytest.approx(
        -edge_sector_bearing
    )


def test_bad_inputs_are_one_line_errors() -> None:
    with pytest.raises(ValueError, match=re.escape("fx must be > 0 px, got 0.0")):
        column_rays(LOOKING_ALONG_X, 0.0, 79.5, 160)
    with pytest.raises(ValueError, match=re.escape("width must be >= 1 px, got 0")):
        column_rays(LOOKING_ALONG_X, 100.0, 79.5, 0)
    with pytest.raises(ValueError, match=re.escape("rotation must be (3, 3), got (9,)")):
        column_rays(LOOKING_ALONG_X.reshape(-1), 100.0, 79.5, 160)
    with pytest.raises(ValueError, match=re.escape("sector_columns must be >= 1, got 0")):
        _resolve([[1.7, 0.0, 0.5]], columns=0)
    with pytest.raises(ValueError, match=re.escape("bin_edges must hold at least two edges, got 1")):
        resolved_capsules(
            np.zeros((1, 3)), np.zeros(3), LOOKING_ALONG_X, 100.0, 79.5, 160, 5, np.array([1.0])
        )
