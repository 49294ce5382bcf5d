"""Pure, vectorised geometry kernels of the flow depth estimator.

Everything here works on arrays of N points at once, takes plain numpy arrays and returns plain numpy arrays:
no images, no OpenCV, no state. Inputs are assumed already validated by the caller (see
:mod:`estimator.estimator`), so the kernels stay cheap in the per-frame loop.

Notation (OpenCV camera frame: x right, y down, z forward; motion ``X_next = R @ X_prev + t``):

* ``x = (x, y)``: normalised image coordinates of a keypoint in the previous image, ``f = [x, y, 1]`` its ray.
  A static point at z-depth ``d`` in the previous camera is ``X_prev = d f``.
* ``h = R f``; ``g = h_xy / h_z`` is the *derotated* position: where the point would appear in the next image
  had the camera only rotated. ``d' = d h_z`` is the depth "after the rotation".
* ``x'``: observed normalised position in the next image. Projecting ``X_next = d' (h / h_z) + t`` gives the
  exact relation, per image component ``c`` in {x, y}::

      d' (x'_c - g_c) = t_c - x'_c t_z

  ``x' - g`` is the translational flow (the flow left after derotation). Its direction is fixed by the motion:
  ``x' - g = (t_xy - g t_z) / (d' + t_z)``, i.e. it points from the epipole (the focus of expansion,
  ``t_xy / t_z``) through ``g``. That fixed direction is what the epipolar sanity check tests.

All residuals and parallaxes are reported in pixels (normalised offsets scaled by ``[fx, fy]``) so that
thresholds mean the same thing on any camera, and non-square pixels are weighted correctly.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

# Rays whose rotated z-component is below this point (nearly) sideways or backwards after the rotation; the
# derotated position is then undefined (a camera turning > ~89 degrees between frames).
_MIN_ROTATED_Z = 1e-9
# Translational flow / epipolar direction shorter than this (in pixels) carries no usable direction. Far
# below any sensible min_parallax_px, it only guards the divisions.
_TINY_PX = 1e-12

METHODS = ("triangulation", "thesis")


class DepthSolution(NamedTuple):
    """Per-point output of :func:`solve_depth`; every field has shape (N,) and dtype float64.

    Attributes:
        depth: z-depth in the previous camera frame, metres; NaN where undefined (no parallax, ray rotated
            behind the camera). May be negative or tiny for outliers: use :func:`valid_depth_mask`.
        next_depth: z-depth of the point in the next camera frame, metres (``d' + t_z``); NaN where undefined.
        parallax_px: Magnitude of the translational flow that the depth was computed from, in pixels: the
            full ``|x' - g|`` for triangulation, the chosen component for the thesis method.
        epipolar_error_px: Distance in pixels of the observed point from the line on which the motion says
            it must lie (perpendicular to the expected flow direction); ``inf`` where the motion gives no
            direction (zero translation, point at the focus of expansion).
    """

    depth: np.ndarray
    next_depth: np.ndarray
    parallax_px: np.ndarray
    epipolar_error_px: np.ndarray


def rotation_to_euler_zyx(rotation: np.ndarray) -> tuple[float, float, float]:
    """Decompose a rotation matrix into Z-Y-X Euler angles.

    Convention: ``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)`` with right-handed rotations about the camera axes.
    At gimbal lock (``|pitch| = 90°``) roll is set to 0 and yaw absorbs the remaining rotation, so the
    round trip through :func:`euler_zyx_to_rotation` stays exact.

    Args:
        rotation: (3, 3) proper rotation matrix.

    Returns:
        ``(roll, pitch, yaw)`` in radians; pitch in [-pi/2, pi/2].
    """
    sin_pitch = float(np.clip(-rotation[2, 0], -1.0, 1.0))
    pitch = float(np.arcsin(sin_pitch))
    cos_pitch = float(np.hypot(rotation[2, 1], rotation[2, 2]))
    if cos_pitch > 1e-9:
        roll = float(np.arctan2(rotation[2, 1], rotation[2, 2]))
        yaw = float(np.arctan2(rotation[1, 0], rotation[0, 0]))
    else:
        roll = 0.0
        yaw = float(np.arctan2(-rotation[0, 1], rotation[1, 1]))
    return roll, pitch, yaw


def euler_zyx_to_rotation(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Rotation matrix ``Rz(yaw) @ Ry(pitch) @ Rx(roll)`` (inverse of :func:`rotation_to_euler_zyx`).

    Args:
        roll: Rotation about x in radians.
        pitch: Rotation about y in radians.
        yaw: Rotation about z in radians.

    Returns:
        (3, 3) float64 rotation matrix.
    """
    cr, sr = np.cos(roll), np.sin(roll)
    cp, sp = np.cos(pitch), np.sin(pitch)
    cy, sy = np.cos(yaw), np.sin(yaw)
    about_x = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    about_y = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    about_z = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    return about_z @ about_y @ about_x


def derotate(normalized: np.ndarray, rotation: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where each previous-image point would appear in the next image under the rotation alone.

    Args:
        normalized: (N, 2) normalised image coordinates in the previous image.
        rotation: (3, 3) rotation from the previous to the next camera frame.

    Returns:
        ``(derotated, rotated_z)``: (N, 2) derotated normalised positions ``g`` (NaN where the rotated ray
        points sideways or backwards) and (N,) ``h_z``, the z-component of the rotated ray ``R f``.
    """
    normalized = np.asarray(normalized, dtype=np.float64).reshape(-1, 2)
    rotated_x, rotated_y, rotated_z = _rotate_rays(normalized, rotation)
    derotated = np.empty_like(normalized)
    ahead = rotated_z > _MIN_ROTATED_Z
    with np.errstate(divide="ignore", invalid="ignore"):
        derotated[:, 0] = np.where(ahead, rotated_x / rotated_z, np.nan)
        derotated[:, 1] = np.where(ahead, rotated_y / rotated_z, np.nan)
    return derotated, rotated_z


def _rotate_rays(normalized: np.ndarray, rotation: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    # R @ [x, y, 1] per point, column by column: on a few hundred points a handful of 1-D operations beats
    # building (N, 3) arrays and a matrix product, whose fixed costs dominated the depth stage.
    x, y = normalized[:, 0], normalized[:, 1]
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = np.asarray(rotation, dtype=np.float64).tolist()
    return r00 * x + r01 * y + r02, r10 * x + r11 * y + r12, r20 * x + r21 * y + r22


def project_points(points_3d: np.ndarray) -> np.ndarray:
    """Perspective projection of (N, 3) camera-frame points to (N, 2) normalised coordinates ``(x/z, y/z)``.

    Points with ``z <= 0`` (behind the camera) project to NaN.
    """
    points_3d = np.asarray(points_3d, dtype=np.float64).reshape(-1, 3)
    projected = np.full((points_3d.shape[0], 2), np.nan)
    np.divide(points_3d[:, :2], points_3d[:, 2:3], out=projected, where=points_3d[:, 2:3] > 0.0)
    return projected


def solve_depth(
    normalized_prev: np.ndarray,
    normalized_next: np.ndarray,
    rotation: np.ndarray,
    translation: np.ndarray,
    focal_scale: np.ndarray,
    method: str = "triangulation",
) -> DepthSolution:
    """Depth of each tracked point from its correspondence and the known camera motion.

    ``method="triangulation"`` solves ``d' (x' - g) = t_xy - x' t_z`` in the least-squares sense over both
    image components (weighted in pixels)::

        d' = (x' - g) · (t_xy - x' t_z) / |x' - g|²,      d = d' / h_z

    ``method="thesis"`` follows the thesis: derotate with the rotation rebuilt from its Euler angles
    (eq. 4.15; exact, so a pure rotation leaves zero flow), then take, per point, the image component with the
    larger derotated flow (Fig. 24) and solve that component alone,
    ``d' = (t_c - x'_c t_z) / (x'_c - g_c)``. For motion along z this is eq. 4.12 (the offset from the focus
    of expansion over the flow); for motion along x or y it reduces to eq. 4.18 (``t_c / flow_c``).

    Both are exact for exact correspondences. Undefined entries are NaN or inf, never a numpy warning.

    Args:
        normalized_prev: (N, 2) normalised positions in the previous image.
        normalized_next: (N, 2) normalised positions of the same points in the next image.
        rotation: (3, 3) rotation, ``X_next = R @ X_prev + t``.
        translation: (3,) translation in metres.
        focal_scale: (2,) ``[fx, fy]`` in pixels, to express flows and residuals in pixels.
        method: ``"triangulation"`` or ``"thesis"``.

    Returns:
        A :class:`DepthSolution`.

    Raises:
        ValueError: ``method`` is not one of :data:`METHODS`.
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    normalized_next = np.asarray(normalized_next, dtype=np.float64).reshape(-1, 2)
    if method == "thesis":
        rotation = euler_zyx_to_rotation(*rotation_to_euler_zyx(rotation))
    normalized_prev = np.asarray(normalized_prev, dtype=np.float64).reshape(-1, 2)
    rotated_x, rotated_y, rotated_z = _rotate_rays(normalized_prev, rotation)
    ahead = rotated_z > _MIN_ROTATED_Z
    t_x, t_y, t_z = (float(v) for v in translation)
    f_x, f_y = (float(v) for v in focal_scale)
    next_x, next_y = normalized_next[:, 0], normalized_next[:, 1]

    # Undefined entries (rays turned sideways, zero parallax) come out as NaN/inf and are masked below; one
    # errstate for the whole kernel keeps numpy silent about them.
    with np.errstate(divide="ignore", invalid="ignore"):
        derotated_x = rotated_x / rotated_z
        derotated_y = rotated_y / rotated_z
        flow_x = (next_x - derotated_x) * f_x
        flow_y = (next_y - derotated_y) * f_y
        # Right-hand side of the per-component relation d'(x' - g) = t_xy - x' t_z, in pixel weighting.
        rhs_x = (t_x - next_x * t_z) * f_x
        rhs_y = (t_y - next_y * t_z) * f_y
        if method == "triangulation":
            parallax_sq = flow_x * flow_x + flow_y * flow_y
            parallax_px = np.sqrt(parallax_sq)
            depth_rotated = (flow_x * rhs_x + flow_y * rhs_y) / parallax_sq
        else:
            use_x = np.abs(flow_x) >= np.abs(flow_y)
            chosen_flow = np.where(use_x, flow_x, flow_y)
            parallax_px = np.abs(chosen_flow)
            depth_rotated = np.where(use_x, rhs_x, rhs_y) / chosen_flow
        usable = ahead & (parallax_px > _TINY_PX)
        depth_rotated = np.where(usable, depth_rotated, np.nan)
        depth = depth_rotated / rotated_z

        # The translational flow of a static point must be parallel to (t_xy - g t_z): the direction from
        # the focus of expansion through g (reversed when moving backwards). The component perpendicular to
        # it is what no depth can explain.
        direction_x = (t_x - derotated_x * t_z) * f_x
        direction_y = (t_y - derotated_y * t_z) * f_y
        direction_norm = np.hypot(direction_x, direction_y)
        cross = np.abs(flow_x * direction_y - flow_y * direction_x)
        epipolar_error_px = np.where(direction_norm > _TINY_PX, cross / direction_norm, np.inf)
    return DepthSolution(
        depth=depth,
        next_depth=depth_rotated + t_z,
        parallax_px=np.where(ahead, np.nan_to_num(parallax_px, nan=0.0), 0.0),
        epipolar_error_px=epipolar_error_px,
    )


def valid_depth_mask(
    solution: DepthSolution, min_parallax_px: float, max_epipolar_error_px: float
) -> np.ndarray:
    """Which depths to trust: enough parallax, on the epipolar line, in front of both cameras.

    Args:
        solution: Output of :func:`solve_depth`.
        min_parallax_px: Smallest accepted translational flow in pixels. The depth error of a point is about
            (flow error / parallax), so small parallax (near the focus of expansion, hovering, no translation)
            gives depths dominated by noise.
        max_epipolar_error_px: Largest accepted distance from the epipolar line in pixels. A correct track
            can only be off the line by the flow noise plus the motion error; a mistrack usually is off by
            much more.

    Returns:
        (N,) bool mask. True entries have finite positive depth.
    """
    with np.errstate(invalid="ignore"):
        # NaN compares False, which is exactly "invalid"; errstate only documents that no warning is wanted.
        return (
            (solution.parallax_px >= min_parallax_px)
            & (solution.epipolar_error_px <= max_epipolar_error_px)
            & np.isfinite(solution.depth)
            & (solution.depth > 0.0)
            & (solution.next_depth > 0.0)
        )


def predict_next_pixels(
    pixels: np.ndarray,
    depth: np.ndarray,
    rotation: np.ndarray,
    translation: np.ndarray,
    camera_matrix: np.ndarray,
) -> np.ndarray:
    """Where points seen at ``pixels`` with z-depth ``depth`` appear after the motion (ground-truth flow).

    Args:
        pixels: (N, 2) pixel positions in the previous image.
        depth: (N,) z-depths in metres in the previous camera frame.
        rotation: (3, 3) rotation, ``X_next = R @ X_prev + t``.
        translation: (3,) translation in metres.
        camera_matrix: (3, 3) K.

    Returns:
        (N, 2) pixel positions in the next image; NaN for points that end up behind the next camera.
    """
    fx, fy, cx, cy = camera_matrix[0, 0], camera_matrix[1, 1], camera_matrix[0, 2], camera_matrix[1, 2]
    pixels = np.asarray(pixels, dtype=np.float64).reshape(-1, 2)
    normalized = (pixels - [cx, cy]) / [fx, fy]
    rays = np.column_stack([normalized, np.ones(len(normalized))])
    points_next = (np.asarray(depth, dtype=np.float64)[:, None] * rays) @ rotation.T + translation
    return project_points(points_next) * [fx, fy] + [cx, cy]
