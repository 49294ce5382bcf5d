"""Sector depth histograms: the fixed-size observation built from a variable number of depth points."""

from __future__ import annotations

import math
from typing import overload

import numpy as np
from numpy.typing import ArrayLike

from estimator._validation import require_int_in_range

#: Default depth bin edges in metres: finer near the drone, where obstacles matter. Bins are
#: [0, 1), [1, 2), [2, 3), [3, 5), [5, 8) and the open far bin [8, inf).
DEFAULT_BIN_EDGES: tuple[float, ...] = (0.0, 1.0, 2.0, 3.0, 5.0, 8.0, 13.0)
#: Default sector grid (rows, cols): left / centre / right crossed with up / level / down.
DEFAULT_SECTORS: tuple[int, int] = (3, 3)


def sector_histogram(
    points: ArrayLike,
    depth: ArrayLike,
    valid: ArrayLike,
    image_size: tuple[int, int],
    sectors: tuple[int, int] = DEFAULT_SECTORS,
    bin_edges: ArrayLike = DEFAULT_BIN_EDGES,
) -> np.ndarray:
    """Per image sector, the distribution of valid point depths over depth bins.

    The image is cut into a ``rows × cols`` grid of equal sectors (in the pixel-centre convention: pixel
    ``(u, v)`` covers ``[u - 0.5, u + 0.5)``, so sector boundaries fall at multiples of ``width / cols``
    from the image's left edge at ``u = -0.5``). Each valid point counts once in its sector, in the bin of
    its depth. Each sector's counts are then divided by its number of valid points, so:

    * a sector with points sums to 1 over its bins (a distribution; the number of points does not leak in,
      which keeps the observation comparable when the corner count varies with texture and threshold);
    * a sector with no valid point is all zeros (distinguishable from any distribution).

    Bins are ``[e0, e1), [e1, e2), …``; depths below the first edge count in the first bin and depths at or
    beyond the last edge count in the last bin, which is therefore open: ``[e[-2], inf)`` ("far"). Points
    outside the image and invalid points are ignored.

    Args:
        points: (N, 2) pixel positions ``(u, v)``.
        depth: (N,) depths in metres; must be finite where ``valid``.
        valid: (N,) bool mask of points to count.
        image_size: ``(width, height)`` in pixels, positive integers.
        sectors: ``(rows, cols)``, positive integers.
        bin_edges: At least two strictly increasing finite edges in metres; ``len(bin_edges) - 1`` bins.

    Returns:
        float32 array of shape (rows, cols, bins), every entry in [0, 1].

    Raises:
        ValueError: A shape, dtype or length does not match, a valid point has a non-finite position or
            depth, or ``image_size``, ``sectors`` or ``bin_edges`` is malformed.
    """
    grid = SectorGrid(image_size, sectors, bin_edges)
    points, depth, valid = _as_point_arrays(points, depth, valid)
    return grid.histogram(grid.locate(points), depth, valid)


def sector_fraction(
    points: ArrayLike,
    selected: ArrayLike,
    among: ArrayLike,
    image_size: tuple[int, int],
    sectors: tuple[int, int] = DEFAULT_SECTORS,
) -> np.ndarray:
    """Per image sector, the fraction of the ``among`` points that are also ``selected``.

    For example the share of tracked points that got no valid depth: in forward flight those are the far
    points and the points near the focus of expansion, whose parallax is too small to range. Sectors follow
    :func:`sector_histogram`; a sector without ``among`` points is 0.

    Args:
        points: (N, 2) pixel positions ``(u, v)``.
        selected: (N,) bool mask; only its entries inside ``among`` count.
        among: (N,) bool mask of the points to count in each sector; positions must be finite there.
        image_size: ``(width, height)`` in pixels, positive integers.
        sectors: ``(rows, cols)``, positive integers.

    Returns:
        float32 array of shape (rows, cols), every entry in [0, 1].

    Raises:
        ValueError: A shape, dtype or length does not match, an ``among`` point has a non-finite position, or
            ``image_size`` or ``sectors`` is malformed.
    """
    grid = SectorGrid(image_size, sectors)
    points, _, among = _as_point_arrays(points, None, among, mask_name="among")
    selected = np.asarray(selected)
    if selected.shape != among.shape or selected.dtype != np.bool_:
        raise ValueError(
            f"selected must be a bool (N,) array like among ({among.shape}), got shape {selected.shape} and "
            f"dtype {selected.dtype}"
        )
    return grid.fraction(grid.locate(points), selected, among)


def sector_counts(
    points: ArrayLike,
    counted: ArrayLike,
    image_size: tuple[int, int],
    sectors: tuple[int, int] = DEFAULT_SECTORS,
) -> np.ndarray:
    """Per image sector, how many of the ``counted`` points lie in it (sectors as :func:`sector_histogram`).

    Returns:
        float32 array of shape (rows, cols) of non-negative counts.

    Raises:
        ValueError: A shape, dtype or length does not match, a counted point has a non-finite position, or
            ``image_size`` or ``sectors`` is malformed.
    """
    grid = SectorGrid(image_size, sectors)
    points, _, counted = _as_point_arrays(points, None, counted, mask_name="counted")
    return grid.counts(grid.locate(points), counted)


def sector_near_depth(
    points: ArrayLike,
    depth: ArrayLike,
    valid: ArrayLike,
    image_size: tuple[int, int],
    sectors: tuple[int, int] = DEFAULT_SECTORS,
    quantile: float = 0.1,
) -> np.ndarray:
    """Per image sector, how near its nearest surface is, robustly: a low quantile of its valid depths.

    A histogram says how a sector's depths are spread, not how near the nearest one is. The minimum would say
    that, but one stray depth sets it; here a sector's depths are sorted and the one at rank
    ``floor(quantile · (n - 1))`` is taken, but never the single nearest when the sector has two or more (so
    one outlier cannot set it). Sectors as :func:`sector_histogram`.

    Args:
        points, depth, valid, image_size, sectors: As :func:`sector_histogram`.
        quantile: The quantile of each sector's depths, in [0, 1].

    Returns:
        float32 array of shape (rows, cols): depths in metres, ``inf`` where a sector has no valid point.

    Raises:
        ValueError: As :func:`sector_histogram`, or ``quantile`` is outside [0, 1].
    """
    if isinstance(quantile, bool) or not isinstance(quantile, (int, float)) or not 0.0 <= quantile <= 1.0:
        raise ValueError(f"quantile must be a number in [0, 1], got {quantile!r}")
    grid = SectorGrid(image_size, sectors)
    points, depth, valid = _as_point_arrays(points, depth, valid)
    return grid.near_depth(grid.locate(points), depth, valid, quantile)


class SectorGrid:
    """One camera's sector grid and depth bins, checked once, for a caller that bins many frames of the same
    camera (the FlowNav env, every step) where the functions above would check the same arguments each time.

    :meth:`locate` finds each point's sector once per frame; every product of that frame (histogram, fraction,
    counts, near depth) reuses it. The methods trust their arrays (the functions above check them): (N,)
    bool masks, (N,) depths finite where counted. Their results equal the functions' for the same input.

    Args:
        image_size, sectors, bin_edges: As :func:`sector_histogram`.

    Raises:
        ValueError: As :func:`sector_histogram` for these three arguments.
    """

    def __init__(
        self,
        image_size: tuple[int, int],
        sectors: tuple[int, int] = DEFAULT_SECTORS,
        bin_edges: ArrayLike = DEFAULT_BIN_EDGES,
    ) -> None:
        self.image_size = _as_pair("image_size", image_size, "(width, height)")
        self.sectors = _as_pair("sectors", sectors, "(rows, cols)")
        self.bin_edges = _as_bin_edges(bin_edges)
        self.bin_edges.flags.writeable = False
        self.shape = (*self.sectors, len(self.bin_edges) - 1)

    def locate(self, points: np.ndarray) -> np.ndarray:
        """(N,) flat sector index (row-major) of each of the (N, 2) ``points``; -1 outside the image (or not
        finite)."""
        width, height = self.image_size
        rows, cols = self.sectors
        u = points[:, 0].astype(np.float64) + 0.5
        v = points[:, 1].astype(np.float64) + 0.5
        inside = (u >= 0.0) & (u < width) & (v >= 0.0) & (v < height)
        # min() guards the float edge case u * cols / width rounding up to cols for u just below width.
        column = np.minimum((u[inside] * cols / width).astype(np.intp), cols - 1)
        row = np.minimum((v[inside] * rows / height).astype(np.intp), rows - 1)
        sector = np.full(len(u), -1, np.intp)
        sector[inside] = row * cols + column
        return sector

    def histogram(self, sector: np.ndarray, depth: np.ndarray, counted: np.ndarray) -> np.ndarray:
        """:func:`sector_histogram` of the ``counted`` points, whose sectors :meth:`locate` gave."""
        keep = counted & (sector >= 0)
        bins = self.shape[2]
        depth = np.asarray(depth, np.float64)[keep]
        depth_bin = np.clip(np.searchsorted(self.bin_edges, depth, side="right") - 1, 0, bins - 1)
        counts = np.bincount(sector[keep] * bins + depth_bin, minlength=math.prod(self.shape))
        counts = counts.reshape(self.shape)
        per_sector = counts.sum(axis=2, keepdims=True)
        histogram = np.zeros(self.shape, dtype=np.float32)
        np.divide(counts, per_sector, out=histogram, where=per_sector > 0, casting="unsafe")
        return histogram

    def fraction(self, sector: np.ndarray, selected: np.ndarray, among: np.ndarray) -> np.ndarray:
        """:func:`sector_fraction`: per sector, the share of the ``among`` points that are ``selected``."""
        keep = among & (sector >= 0)
        count = math.prod(self.sectors)
        totals = np.bincount(sector[keep], minlength=count)
        hits = np.bincount(sector[keep], weights=selected[keep], minlength=count)
        fraction = np.zeros(count, dtype=np.float32)
        np.divide(hits, totals, out=fraction, where=totals > 0, casting="unsafe")
        return fraction.reshape(self.sectors)

    def counts(self, sector: np.ndarray, counted: np.ndarray) -> np.ndarray:
        """:func:`sector_counts`: how many ``counted`` points each sector holds."""
        keep = counted & (sector >= 0)
        counts = np.bincount(sector[keep], minlength=math.prod(self.sectors))
        return counts.astype(np.float32).reshape(self.sectors)

    def near_depth(
        self, sector: np.ndarray, depth: np.ndarray, counted: np.ndarray, quantile: float = 0.1
    ) -> np.ndarray:
        """:func:`sector_near_depth` of the ``counted`` points (``quantile`` unchecked here)."""
        keep = counted & (sector >= 0)
        sector, depths = sector[keep], np.asarray(depth, np.float64)[keep]
        order = np.lexsort((depths, sector))
        counts = np.bincount(sector, minlength=math.prod(self.sectors))
        starts = np.cumsum(counts) - counts
        rank = np.maximum((quantile * (counts - 1)).astype(np.intp), np.minimum(1, counts - 1))
        occupied = counts > 0
        near = np.full(len(counts), np.inf)
        near[occupied] = depths[order][starts[occupied] + rank[occupied]]
        return near.astype(np.float32).reshape(self.sectors)


def _as_pair(name: str, value: object, meaning: str) -> tuple[int, int]:
    if isinstance(value, np.ndarray):
        value = tuple(value.tolist())
    if not isinstance(value, (tuple, list)) or len(value) != 2:
        raise ValueError(f"{name} must be a pair of positive integers {meaning}, got {value!r}")
    first = require_int_in_range(f"{name}[0]", value[0], 1)
    second = require_int_in_range(f"{name}[1]", value[1], 1)
    return first, second


def _as_bin_edges(value: ArrayLike) -> np.ndarray:
    try:
        edges = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"bin_edges must be a sequence of numbers, got {value!r}") from None
    if edges.ndim != 1 or len(edges) < 2:
        raise ValueError(f"bin_edges must be a 1-D sequence of at least 2 edges, got shape {edges.shape}")
    if not np.all(np.isfinite(edges)):
        raise ValueError(f"bin_edges must be finite, got {edges.tolist()}")
    if not np.all(np.diff(edges) > 0.0):
        raise ValueError(f"bin_edges must be strictly increasing, got {edges.tolist()}")
    return edges


@overload
def _as_point_arrays(
    points: ArrayLike, depth: ArrayLike, valid: ArrayLike, mask_name: str = "valid"
) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...


@overload
def _as_point_arrays(
    points: ArrayLike, depth: None, valid: ArrayLike, mask_name: str = "valid"
) -> tuple[np.ndarray, None, np.ndarray]: ...


def _as_point_arrays(
    points: ArrayLike, depth: ArrayLike | None, valid: ArrayLike, mask_name: str = "valid"
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    """Checked arrays; ``depth=None`` checks only the points and the mask."""
    points = _pixel_positions(points)
    depth = None if depth is None else _depth_column(depth)
    valid = _mask(valid, mask_name)
    arrays = {"points": points, **({"depth": depth} if depth is not None else {}), mask_name: valid}
    if len({len(array) for array in arrays.values()}) != 1:
        raise ValueError(
            f"{', '.join(list(arrays)[:-1])} and {mask_name} must have the same length N, got "
            f"{', '.join(str(len(a)) for a in list(arrays.values())[:-1])} and {len(valid)}"
        )
    if depth is not None and not np.all(np.isfinite(depth[valid])):
        raise ValueError(f"depth must be finite where {mask_name} is True")
    if not np.all(np.isfinite(points[valid])):
        raise ValueError(f"points must be finite where {mask_name} is True")
    return points, (None if depth is None else depth.astype(np.float64, copy=False)), valid


def _pixel_positions(points: ArrayLike) -> np.ndarray:
    points = np.asarray(points)
    if points.ndim != 2 or points.shape[1] != 2 or not np.issubdtype(points.dtype, np.number):
        raise ValueError(f"points must be a numeric (N, 2) array of pixel positions, got {points.shape}")
    return points


def _depth_column(depth: ArrayLike) -> np.ndarray:
    depth = np.asarray(depth)
    if depth.ndim != 1 or not np.issubdtype(depth.dtype, np.number):
        raise ValueError(f"depth must be a numeric (N,) array, got shape {depth.shape}")
    return depth


def _mask(valid: ArrayLike, mask_name: str) -> np.ndarray:
    valid = np.asarray(valid)
    if valid.ndim != 1 or valid.dtype != np.bool_:
        raise ValueError(
            f"{mask_name} must be a bool (N,) array, got shape {valid.shape} and dtype {valid.dtype}"
        )
    return valid
