"""Input checks shared by the estimator modules.

Every public entry point validates its arguments with these helpers so that bad input fails early with a
``ValueError`` naming the argument, the value received and what was expected (``assert`` would vanish under
``python -O``).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

# A rotation matrix from a simulator or an IMU pipeline carries float rounding; anything further from
# orthonormal than this is a bug upstream (e.g. a transposed pose or a scaled matrix), not rounding.
ROTATION_TOLERANCE = 1e-5


def require_positive_finite(name: str, value: object) -> float:
    """Return ``value`` as a float, requiring 0 < value < inf."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a positive finite number (0 < {name} < inf), got {value!r}")
    number = float(value)
    if not math.isfinite(number) or number <= 0.0:
        raise ValueError(f"{name} must be a positive finite number (0 < {name} < inf), got {value!r}")
    return number


def require_non_negative_finite(name: str, value: object) -> float:
    """Return ``value`` as a float, requiring 0 <= value < inf."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a finite number >= 0 (0 <= {name} < inf), got {value!r}")
    number = float(value)
    if not math.isfinite(number) or number < 0.0:
        raise ValueError(f"{name} must be a finite number >= 0 (0 <= {name} < inf), got {value!r}")
    return number


def require_finite(name: str, value: object) -> float:
    """Return ``value`` as a float, requiring it to be finite."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    number = float(value)
    if not math.isfinite(number):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    return number


def require_int_in_range(name: str, value: object, low: int, high: int | None = None) -> int:
    """Return ``value`` as an int, requiring low <= value (<= high when given)."""
    allowed = f"{low} <= {name}" + (f" <= {high}" if high is not None else "")
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name} must be an integer with {allowed}, got {value!r}")
    number = int(value)
    if number < low or (high is not None and number > high):
        raise ValueError(f"{name} must be an integer with {allowed}, got {value!r}")
    return number


def require_bool(name: str, value: object) -> bool:
    """Return ``value`` as a bool, requiring an actual bool (not 0/1 or a string)."""
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def as_rotation_matrix(name: str, value: ArrayLike) -> NDArray[np.float64]:
    """Return ``value`` as a float64 (3, 3) proper rotation matrix (R^T R = I, det R = +1)."""
    matrix = _as_float_array(name, value, "a 3x3 rotation matrix")
    if matrix.shape != (3, 3):
        raise ValueError(f"{name} must be a 3x3 rotation matrix, got an array of shape {matrix.shape}")
    # Plain floats: this runs on every frame, where numpy's per-call cost on a 3x3 is larger than the maths.
    entries = matrix.ravel().tolist()
    if not all(math.isfinite(entry) for entry in entries):
        raise ValueError(f"{name} must be a finite 3x3 rotation matrix, got non-finite entries")
    a, b, c, d, e, f, g, h, i = entries
    orthogonality_error = max(  # the entries of R^T R - I, written out
        abs(a * a + d * d + g * g - 1.0),
        abs(b * b + e * e + h * h - 1.0),
        abs(c * c + f * f + i * i - 1.0),
        abs(a * b + d * e + g * h),
        abs(a * c + d * f + g * i),
        abs(b * c + e * f + h * i),
    )
    determinant = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
    if orthogonality_error > ROTATION_TOLERANCE or abs(determinant - 1.0) > ROTATION_TOLERANCE:
        raise ValueError(
            f"{name} must be a rotation matrix (R^T R = I and det R = +1 within {ROTATION_TOLERANCE:g}), "
            f"got max|R^T R - I| = {orthogonality_error:.3g} and det R = {determinant:.6g}"
        )
    return matrix


def as_translation_vector(name: str, value: ArrayLike) -> NDArray[np.float64]:
    """Return ``value`` as a finite float64 (3,) vector; (3, 1) and (1, 3) are accepted and flattened."""
    vector = _as_float_array(name, value, "a finite 3-vector in metres")
    if vector.size != 3 or vector.ndim > 2:
        raise ValueError(f"{name} must be a finite 3-vector in metres, got an array of shape {vector.shape}")
    vector = vector.reshape(3)
    if not np.all(np.isfinite(vector)):
        raise ValueError(f"{name} must be a finite 3-vector in metres, got {vector.tolist()}")
    return vector


def _as_float_array(name: str, value: ArrayLike, expected: str) -> NDArray[np.float64]:
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name} must be {expected}, got {type(value).__name__}: {error}") from None
    return array


def as_grid(name: str, value: object) -> tuple[int, int]:
    """Return ``value`` as a ``(rows, cols)`` pair of integers, each in [1, 64]."""
    if not isinstance(value, (tuple, list)) or len(value) != 2:
        raise ValueError(f"{name} must be a (rows, cols) pair of integers in [1, 64], got {value!r}")
    rows = require_int_in_range(f"{name}[0] (rows)", value[0], 1, 64)
    cols = require_int_in_range(f"{name}[1] (cols)", value[1], 1, 64)
    return rows, cols
