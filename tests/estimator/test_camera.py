"""Tests of estimator.camera: CameraIntrinsics construction, validation and the FOV formula."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from estimator import CameraIntrinsics


def test_from_fov_vertical_uses_height_and_centres_principal_point():
    intrinsics = CameraIntrinsics.from_fov(640, 480, 90.0)
    # tan(45°) = 1, so f is half the height.
    assert intrinsics.fx == pytest.approx(240.0)
    assert intrinsics.fy == pytest.approx(240.0)
    assert (intrinsics.cx, intrinsics.cy) == (319.5, 239.5)
    assert (intrinsics.width, intrinsics.height) == (640, 480)


def test_from_fov_horizontal_uses_width():
    intrinsics = CameraIntrinsics.from_fov(640, 480, 60.0, axis="horizontal")
    assert intrinsics.fx == pytest.approx(320.0 / math.tan(math.radians(30.0)))


def test_from_fov_reproduces_the_field_of_view():
    intrinsics = CameraIntrinsics.from_fov(320, 240, 45.0)
    # The ray through the top image edge (v = -0.5) is at half the FOV from the axis.
    half_angle = math.degrees(math.atan((intrinsics.cy + 0.5) / intrinsics.fy))
    assert half_angle == pytest.approx(22.5)


def test_matrix_and_normalize_round_trip():
    intrinsics = CameraIntrinsics(fx=500.0, fy=450.0, cx=320.0, cy=240.0, width=640, height=480)
    np.testing.assert_array_equal(
        intrinsics.matrix, [[500.0, 0.0, 320.0], [0.0, 450.0, 240.0], [0.0, 0.0, 1.0]]
    )
    pixels = np.array([[0.0, 0.0], [320.0, 240.0], [639.0, 100.0]])
    normalized = intrinsics.normalize(pixels)
    np.testing.assert_allclose(normalized[1], [0.0, 0.0])
    np.testing.assert_allclose(normalized[0], [-320.0 / 500.0, -240.0 / 450.0])
    np.testing.assert_allclose(intrinsics.denormalize(normalized), pixels)
    assert intrinsics.image_size == (640, 480)


def test_intrinsics_are_frozen():
    intrinsics = CameraIntrinsics.from_fov(64, 48, 60.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        intrinsics.fx = 1.0  # type: ignore[misc]


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("fx", 0.0, r"fx must be a positive finite number \(0 < fx < inf\), got 0.0"),
        ("fy", -1.0, r"fy must be a positive finite number"),
        ("fx", float("inf"), r"fx must be a positive finite number"),
        ("fy", float("nan"), r"fy must be a positive finite number"),
        ("cx", float("nan"), r"cx must be a finite number"),
        ("cy", "1", r"cy must be a finite number"),
        ("width", 0, r"width must be an integer with 1 <= width, got 0"),
        ("height", 2.5, r"height must be an integer with 1 <= height, got 2.5"),
        ("width", True, r"width must be an integer"),
    ],
)
def test_invalid_field_names_the_field_and_range(field, value, message):
    params = {"fx": 500.0, "fy": 500.0, "cx": 319.5, "cy": 239.5, "width": 640, "height": 480}
    params[field] = value
    with pytest.raises(ValueError, match=message):
        CameraIntrinsics(**params)


@pytest.mark.parametrize(
    ("args", "kwargs", "message"),
    [
        ((640, 480, 0.0), {}, r"fov_deg must be in the open interval \(0, 180\)"),
        ((640, 480, 180.0), {}, r"fov_deg must be in the open interval \(0, 180\)"),
        ((640, 480, float("nan")), {}, r"fov_deg must be a finite number"),
        ((640, 480, 60.0), {"axis": "diagonal"}, r"axis must be one of \('vertical', 'horizontal'\)"),
        ((0, 480, 60.0), {}, r"width must be an integer with 1 <= width"),
        ((640, -1, 60.0), {}, r"height must be an integer with 1 <= height"),
    ],
)
def test_from_fov_rejects_bad_input(args, kwargs, message):
    with pytest.raises(ValueError, match=message):
        CameraIntrinsics.from_fov(*args, **kwargs)


def test_rays_are_normalised_coordinates_with_unit_z():
    intrinsics = CameraIntrinsics.from_fov(64, 48, 60.0)
    pixels = np.array([[intrinsics.cx, intrinsics.cy], [0.0, 0.0]])
    rays = intrinsics.rays(pixels)
    np.testing.assert_array_equal(rays[:, :2], intrinsics.normalize(pixels))
    np.testing.assert_array_equal(rays[:, 2], [1.0, 1.0])
    np.testing.assert_array_equal(rays[0], [0.0, 0.0, 1.0])
    assert intrinsics.rays(np.zeros((0, 2))).shape == (0, 3)
