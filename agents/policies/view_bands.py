"""Regions of the camera's view as shares of the image's width, read off a depth histogram of any column count.

The env cuts the image into ``cols`` equal columns (``histogram_sectors``; an agent may ask for another count). A
rule written in columns ("the middle column", "one column either side") reads a different part of the view at
each count: at 15 columns the middle one is a third as wide as at 5. The rules state their regions here instead,
as bands of the image's width (0 its left edge, 1 its right), so that they see the same angles at any
resolution. Shares are :class:`~fractions.Fraction` so that a band's edge that falls on a column's edge gives
weights of exactly 0 and 1: at the count the rules were tuned at (5 columns), their laws give the same numbers
bit for bit as when they were written in columns.
"""

from __future__ import annotations

import functools
import math
from fractions import Fraction

import numpy as np


def _check_band(cols: int, start: Fraction, stop: Fraction) -> None:
    if isinstance(cols, bool) or not isinstance(cols, int) or cols < 1:
        raise ValueError(f"columns must be an integer >= 1, got {cols!r}")
    if not 0 <= start < stop <= 1:
        raise ValueError(f"a band of the view must satisfy 0 <= start < stop <= 1, got [{start}, {stop})")


def column_weights(cols: int, start: Fraction, stop: Fraction) -> np.ndarray:
    """How much of each of ``cols`` equal columns lies in the band [``start``, ``stop``) of the image's width, as a
    share of the column: 1 inside, 0 outside, a fraction where the band's edge cuts it.

    Raises:
        ValueError: ``cols`` is not a positive integer, or the band is not 0 <= start < stop <= 1.
    """
    _check_band(cols, start, stop)
    return _column_weights(cols, Fraction(start), Fraction(stop))


# The bands' geometry depends only on the column count, so a rule computes it once per count, not every step
# (Fraction arithmetic is slow); the cached arrays are read-only so that no caller can change them for the next.
@functools.lru_cache(maxsize=64)
def _column_weights(cols: int, start: Fraction, stop: Fraction) -> np.ndarray:
    low, high = start * cols, stop * cols
    weights = np.array(
        [float(max(min(high, Fraction(j + 1)) - max(low, Fraction(j)), Fraction(0))) for j in range(cols)]
    )
    weights.setflags(write=False)
    return weights


def band_mean(per_column: np.ndarray, start: Fraction, stop: Fraction) -> np.ndarray:
    """The mean over the band [``start``, ``stop``) of the view of a value per column (batch, cols), each column
    weighted by its share inside the band (:func:`column_weights`): (batch,).

    Raises:
        ValueError: as :func:`column_weights`.
    """
    weights = column_weights(per_column.shape[-1], start, stop)
    inside = np.flatnonzero(weights)
    if np.all(weights[inside] == 1.0):  # whole columns: a plain mean, as a rule written in columns takes it
        return np.asarray(per_column[..., inside].mean(axis=-1))
    return np.asarray(np.average(per_column[..., inside], axis=-1, weights=weights[inside]))


def band_columns(cols: int, start: Fraction, stop: Fraction) -> np.ndarray:
    """The columns that stand for the band [``start``, ``stop``) of the view where a value is read whole (a
    maximum): those whose centres lie in it, or, in a band narrower than a column that holds no centre, the one or
    two columns nearest its middle.

    Raises:
        ValueError: as :func:`column_weights`.
    """
    _check_band(cols, start, stop)
    return _band_columns(cols, Fraction(start), Fraction(stop))


@functools.lru_cache(maxsize=64)
def _band_columns(cols: int, start: Fraction, stop: Fraction) -> np.ndarray:
    centres = [Fraction(2 * j + 1, 2 * cols) for j in range(cols)]
    inside = [j for j, centre in enumerate(centres) if start <= centre <= stop]
    if not inside:
        middle = (start + stop) / 2
        nearest = min(abs(centre - middle) for centre in centres)
        inside = [j for j, centre in enumerate(centres) if abs(centre - middle) == nearest]
    columns = np.array(inside)
    columns.setflags(write=False)
    return columns


def triangle_kernel(cols: int, half_width: Fraction) -> np.ndarray:
    """Weights, summing to 1, of a triangular smoothing across columns that falls to 0 at ``half_width`` of the
    image's width either side: ``2k + 1`` weights for the column offsets -k..k. At 5 columns and a half-width of
    2/5 it is [1/4, 1/2, 1/4].

    Raises:
        ValueError: ``cols`` is not a positive integer, or ``half_width`` not in (0, 1].
    """
    if isinstance(cols, bool) or not isinstance(cols, int) or cols < 1:
        raise ValueError(f"columns must be an integer >= 1, got {cols!r}")
    if not 0 < half_width <= 1:
        raise ValueError(f"a kernel's half-width must be in (0, 1] of the view, got {half_width}")
    return _triangle_kernel(cols, Fraction(half_width))


@functools.lru_cache(maxsize=64)
def _triangle_kernel(cols: int, half_width: Fraction) -> np.ndarray:
    reach = half_width * cols  # in columns
    offsets = range(-math.ceil(reach) + 1, math.ceil(reach))
    weights = np.array([float(1 - Fraction(abs(k)) / reach) for k in offsets])
    kernel = weights / weights.sum()
    kernel.setflags(write=False)
    return kernel


def smooth_across_columns(values: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """``values`` (batch, cols) smoothed across columns with ``kernel`` (odd length), the edge columns repeated
    beyond the image's edges."""
    reach = len(kernel) // 2
    padded = np.pad(values, ((0, 0), (reach, reach)), mode="edge")
    cols = values.shape[1]
    smoothed = kernel[0] * padded[:, :cols]
    for k in range(1, len(kernel)):  # summed left to right, as [1/4, 1/2, 1/4] was written out
        smoothed = smoothed + kernel[k] * padded[:, k : k + cols]
    return smoothed
