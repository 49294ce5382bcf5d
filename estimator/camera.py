"""Pinhole camera intrinsics in the OpenCV convention.

Pixel coordinates ``(u, v)``: u grows to the right, v grows downwards, and the centre of the top-left pixel is
``(0, 0)`` (OpenCV's convention, the one FAST and ``calcOpticalFlowPyrLK`` report points in). A point
``(x, y, z)`` in the camera frame (x right, y down, z forward, metres) projects to
``u = fx * x / z + cx`` and ``v = fy * y / z + cy``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from estimator._validation import require_finite, require_int_in_range, require_positive_finite

_FOV_AXES = ("vertical", "horizontal")


@dataclass(frozen=True)
class CameraIntrinsics:
    """Intrinsic parameters of an undistorted pinhole camera.

    Attributes:
        fx: Focal length along u in pixels; positive and finite.
        fy: Focal length along v in pixels; positive and finite.
        cx: Principal point u in pixels (pixel-centre convention, see the module docstring); finite.
        cy: Principal point v in pixels; finite.
        width: Image width in pixels; an integer >= 1.
        height: Image height in pixels; an integer >= 1.

    Raises:
        ValueError: A field is outside its range; the message names the field and the allowed range.
    """

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int

    def __post_init__(self) -> None:
        # Frozen dataclass: normalise the stored types through object.__setattr__ so that e.g. numpy
        # scalars do not leak into hashes and reprs.
        object.__setattr__(self, "fx", require_positive_finite("fx", self.fx))
        object.__setattr__(self, "fy", require_positive_finite("fy", self.fy))
        object.__setattr__(self, "cx", require_finite("cx", self.cx))
        object.__setattr__(self, "cy", require_finite("cy", self.cy))
        object.__setattr__(self, "width", require_int_in_range("width", self.width, 1))
        object.__setattr__(self, "height", require_int_in_range("height", self.height, 1))

    @classmethod
    def from_fov(cls, width: int, height: int, fov_deg: float, axis: str = "vertical") -> CameraIntrinsics:
        """Intrinsics of an ideal camera from its field of view (thesis eq. 4.16).

        ``f = (size / 2) / tan(fov / 2)`` where ``size`` is the image height for a vertical FOV and the width
        for a horizontal one. Pixels are square (``fx = fy = f``) and the principal point is the image centre
        in the pixel-centre convention: ``cx = (width - 1) / 2``, ``cy = (height - 1) / 2``. The default axis
        is vertical because MuJoCo's camera ``fovy`` is the vertical field of view.

        Args:
            width: Image width in pixels, an integer >= 1.
            height: Image height in pixels, an integer >= 1.
            fov_deg: Full field of view in degrees along ``axis``, 0 < fov_deg < 180.
            axis: ``"vertical"`` (default) or ``"horizontal"``.

        Returns:
            The intrinsics.

        Raises:
            ValueError: A size is not a positive integer, ``fov_deg`` is outside (0, 180) or ``axis`` is
                unknown.
        """
        width = require_int_in_range("width", width, 1)
        height = require_int_in_range("height", height, 1)
        fov = require_finite("fov_deg", fov_deg)
        if not 0.0 < fov < 180.0:
            raise ValueError(f"fov_deg must be in the open interval (0, 180) degrees, got {fov_deg!r}")
        if axis not in _FOV_AXES:
            raise ValueError(f"axis must be one of {_FOV_AXES}, got {axis!r}")
        size = height if axis == "vertical" else width
        focal = (size / 2.0) / math.tan(math.radians(fov) / 2.0)
        return cls(
            fx=focal, fy=focal, cx=(width - 1) / 2.0, cy=(height - 1) / 2.0, width=width, height=height
        )

    @property
    def matrix(self) -> np.ndarray:
        """The 3x3 camera matrix ``K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]`` (float64, a fresh copy)."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]], dtype=np.float64)

    @property
    def image_size(self) -> tuple[int, int]:
        """``(width, height)`` in pixels, the order OpenCV and :func:`estimator.sector_histogram` use."""
        return (self.width, self.height)

    @property
    def focal_scale(self) -> np.ndarray:
        """``[fx, fy]`` as a float64 array: multiplies normalised image offsets into pixel offsets."""
        return np.array([self.fx, self.fy], dtype=np.float64)

    def normalize(self, pixels: np.ndarray) -> np.ndarray:
        """Pixel coordinates (N, 2) → normalised coordinates (N, 2) float64: ``((u-cx)/fx, (v-cy)/fy)``."""
        pixels = np.asarray(pixels, dtype=np.float64)
        return (pixels - np.array([self.cx, self.cy])) / self.focal_scale

    def rays(self, pixels: np.ndarray) -> np.ndarray:
        """Pixel coordinates (N, 2) → camera rays ``[x, y, 1]`` (N, 3) float64: a point at z-depth d lies at d · ray.

        Scaling a ray by a z-depth gives the 3-D point, which is how ray casts and depth-to-point conversions
        consume pixels; with zero pixels the result is an empty (0, 3) array.
        """
        normalized = self.normalize(pixels)
        return np.column_stack([normalized, np.ones(len(normalized))])

    def denormalize(self, normalized: np.ndarray) -> np.ndarray:
        """Normalised image coordinates (N, 2) → pixel coordinates (N, 2) float64."""
        normalized = np.asarray(normalized, dtype=np.float64)
        return normalized * self.focal_scale + np.array([self.cx, self.cy])
