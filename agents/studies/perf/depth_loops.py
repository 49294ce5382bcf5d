"""The depth stage written as per-point Python loops (the thesis's style) beside the vectorised kernel, so the
benchmark can state what vectorising bought."""

from __future__ import annotations

import math

import numpy as np

from estimator import CameraIntrinsics, geometry

_MIN_ROTATED_Z = 1e-9
_TINY_PX = 1e-12


def depth_loop_floats(
    points: np.ndarray,
    next_points: np.ndarray,
    rotation: np.ndarray,
    translation: np.ndarray,
    intrinsics: CameraIntrinsics,
    min_parallax_px: float,
    max_epipolar_error_px: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Triangulation depth and validity, one point at a time in plain Python floats.

    Same maths as :func:`estimator.geometry.solve_depth` (``method="triangulation"``) followed by
    :func:`estimator.geometry.valid_depth_mask`: derotate the ray, translational flow in pixels,
    least-squares depth over both components, epipolar distance, checks. Scalars are pulled out of numpy
    first, the fastest a per-point loop gets in CPython.

    Args:
        points, next_points: (N, 2) pixel positions in the previous and next image.
        rotation: (3, 3), ``X_next = R @ X_prev + t``.
        translation: (3,) metres.
        intrinsics: :class:`estimator.CameraIntrinsics`.
        min_parallax_px, max_epipolar_error_px: thresholds of the validity check.

    Returns:
        ``(depth, valid)``: (N,) float64 z-depth (NaN where undefined) and (N,) bool.
    """
    fx, fy, cx, cy = intrinsics.fx, intrinsics.fy, intrinsics.cx, intrinsics.cy
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = rotation.tolist()
    tx, ty, tz = translation.tolist()
    count = len(points)
    depth = [math.nan] * count
    valid = [False] * count
    for i, ((u, v), (u_next, v_next)) in enumerate(zip(points.tolist(), next_points.tolist(), strict=True)):
        x, y = (u - cx) / fx, (v - cy) / fy
        x_next, y_next = (u_next - cx) / fx, (v_next - cy) / fy
        hx = r00 * x + r01 * y + r02
        hy = r10 * x + r11 * y + r12
        hz = r20 * x + r21 * y + r22
        if hz <= _MIN_ROTATED_Z:
            continue
        gx, gy = hx / hz, hy / hz
        flow_x, flow_y = (x_next - gx) * fx, (y_next - gy) * fy
        rhs_x, rhs_y = (tx - x_next * tz) * fx, (ty - y_next * tz) * fy
        parallax_sq = flow_x * flow_x + flow_y * flow_y
        parallax = math.sqrt(parallax_sq)
        if parallax <= _TINY_PX:
            continue
        depth_rotated = (flow_x * rhs_x + flow_y * rhs_y) / parallax_sq
        point_depth = depth_rotated / hz
        depth[i] = point_depth
        dir_x, dir_y = (tx - gx * tz) * fx, (ty - gy * tz) * fy
        dir_norm = math.hypot(dir_x, dir_y)
        epipolar = abs(flow_x * dir_y - flow_y * dir_x) / dir_norm if dir_norm > _TINY_PX else math.inf
        valid[i] = (
            parallax >= min_parallax_px
            and epipolar <= max_epipolar_error_px
            and point_depth > 0.0
            and depth_rotated + tz > 0.0
        )
    return np.array(depth, np.float64), np.array(valid, bool)


def depth_loop_numpy(
    points: np.ndarray,
    next_points: np.ndarray,
    rotation: np.ndarray,
    translation: np.ndarray,
    intrinsics: CameraIntrinsics,
    min_parallax_px: float,
    max_epipolar_error_px: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The same per-point loop written with small numpy vectors per point (ray, rotated ray, flow).

    This is how a per-point loop usually reads when it is written from the formulas (``h = R @ f``); numpy's
    per-call overhead on 2- and 3-vectors makes it several times slower than :func:`depth_loop_floats`.
    Arguments and return value as :func:`depth_loop_floats`.
    """
    focal = intrinsics.focal_scale
    centre = np.array([intrinsics.cx, intrinsics.cy])
    translation_xy, translation_z = translation[:2], translation[2]
    count = len(points)
    depth = np.full(count, np.nan)
    valid = np.zeros(count, bool)
    for i in range(count):
        normalized = (points[i] - centre) / focal
        normalized_next = (next_points[i] - centre) / focal
        rotated = rotation @ np.array([normalized[0], normalized[1], 1.0])
        if rotated[2] <= _MIN_ROTATED_Z:
            continue
        derotated = rotated[:2] / rotated[2]
        flow = (normalized_next - derotated) * focal
        rhs = (translation_xy - normalized_next * translation_z) * focal
        parallax_sq = float(flow @ flow)
        parallax = math.sqrt(parallax_sq)
        if parallax <= _TINY_PX:
            continue
        depth_rotated = float(flow @ rhs) / parallax_sq
        depth[i] = depth_rotated / rotated[2]
        direction = (translation_xy - derotated * translation_z) * focal
        direction_norm = float(np.linalg.norm(direction))
        cross = flow[0] * direction[1] - flow[1] * direction[0]
        epipolar = abs(cross) / direction_norm if direction_norm > _TINY_PX else math.inf
        valid[i] = (
            parallax >= min_parallax_px
            and epipolar <= max_epipolar_error_px
            and depth[i] > 0.0
            and depth_rotated + translation_z > 0.0
        )
    return depth, valid


def depth_vectorised(
    points: np.ndarray,
    next_points: np.ndarray,
    rotation: np.ndarray,
    translation: np.ndarray,
    intrinsics: CameraIntrinsics,
    min_parallax_px: float,
    max_epipolar_error_px: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The estimator's depth stage as it runs in ``FlowDepthEstimator``: normalise, solve, check.

    Arguments and return value as :func:`depth_loop_floats`.
    """
    solution = geometry.solve_depth(
        intrinsics.normalize(points),
        intrinsics.normalize(next_points),
        rotation,
        translation,
        intrinsics.focal_scale,
        "triangulation",
    )
    return solution.depth, geometry.valid_depth_mask(solution, min_parallax_px, max_epipolar_error_px)


DEPTH_FUNCTIONS = {
    "vectorised": depth_vectorised,
    "loop_floats": depth_loop_floats,
    "loop_numpy": depth_loop_numpy,
}
