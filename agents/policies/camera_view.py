"""Which capsules a forward camera sees, and where its observation's histogram puts them: pure functions on
arrays, for the camera-limited planners (:mod:`agents.policies.planner_camera`).

The world is seen from above: capsules are vertical cylinders, circles of (x, y, radius) in the horizontal
plane. One ray leaves the camera per pixel column, through the image's middle row, turned into the world by the
camera's rotation and laid flat; a capsule is seen when some column's first hit within the range is it, so a
nearer capsule hides one behind it. Camera rotations are world-from-camera in OpenCV axes (x right, y down, z
forward), as the env's ``camera`` key gives them (:mod:`flownav_env.privileged`).

The histogram resolves a seen capsule by its front point, the point of its surface nearest the camera: the
centre of the sector column that point falls in (clamped to the image, so a capsule whose front lies beyond the
image's edge lands in the edge sector) and the centre of its z-depth's bin (below the first edge the first bin,
at or past the last edge the last; the last bin's centre is that of its two edges).
"""

from __future__ import annotations

import numpy as np


def column_rays(rotation: np.ndarray, fx: float, cx: float, width: int) -> np.ndarray:
    """Unit horizontal world directions (width, 2) of the rays through each pixel column's middle row.

    Args:
        rotation: (3, 3) world-from-camera rotation, OpenCV axes.
        fx, cx: focal length and principal point along the image's width (px).
        width: image width (px).

    Raises:
        ValueError: ``fx`` or ``width`` not > 0, or ``rotation`` not (3, 3).
    """
    if not fx > 0.0:
        raise ValueError(f"fx must be > 0 px, got {fx!r}")
    if not width >= 1:
        raise ValueError(f"width must be >= 1 px, got {width!r}")
    rotation = np.asarray(rotation, np.float64)
    if rotation.shape != (3, 3):
        raise ValueError(f"rotation must be (3, 3), got {rotation.shape}")
    columns = np.arange(int(width), dtype=np.float64)
    rays = np.stack([(columns - cx) / fx, np.zeros_like(columns), np.ones_like(columns)], axis=1)
    flat = (rays @ rotation.T)[:, :2]
    return flat / np.linalg.norm(flat, axis=1, keepdims=True)


def first_hits(
    origin: np.ndarray, directions: np.ndarray, capsules: np.ndarray, view_range: float
) -> tuple[np.ndarray, np.ndarray]:
    """Each ray's first capsule within ``view_range``: its row in ``capsules`` (-1 for none) and the distance
    to it (m, inf for none; 0 from inside a capsule).

    Args:
        origin: (2,) the rays' start (x, y, m).
        directions: (R, 2) unit directions.
        capsules: (N, 3) x, y of the axis and radius (m).
        view_range: the farthest hit counted (m).
    """
    directions = np.asarray(directions, np.float64).reshape(-1, 2)
    capsules = np.asarray(capsules, np.float64).reshape(-1, 3)
    if len(capsules) == 0:
        return np.full(len(directions), -1), np.full(len(directions), np.inf)
    offset = np.asarray(origin, np.float64)[:2] - capsules[:, :2]  # (N, 2): origin relative to each centre
    along = directions @ offset.T  # (R, N)
    outside = np.einsum("ij,ij->i", offset, offset) - capsules[:, 2] ** 2  # (N,) > 0 outside the circle
    discriminant = along**2 - outside
    entry = -along - np.sqrt(np.maximum(discriminant, 0.0))
    hit = (discriminant >= 0.0) & (entry >= 0.0)
    distance = np.where(hit, entry, np.inf)
    distance = np.where(outside <= 0.0, 0.0, distance)  # inside a capsule, every ray hits it at once
    distance = np.where(distance <= view_range, distance, np.inf)
    nearest = distance.argmin(axis=1)
    first = distance[np.arange(len(directions)), nearest]
    return np.where(np.isfinite(first), nearest, -1), first


def seen_capsules(
    origin: np.ndarray, directions: np.ndarray, capsules: np.ndarray, view_range: float
) -> np.ndarray:
    """Which ``capsules`` (N,) are some ray's first hit within ``view_range`` (:func:`first_hits`'s arguments)."""
    rows, _ = first_hits(origin, directions, capsules, view_range)
    seen = np.zeros(len(np.asarray(capsules).reshape(-1, 3)), bool)
    seen[rows[rows >= 0]] = True
    return seen


def front_points(capsules: np.ndarray, position: np.ndarray) -> np.ndarray:
    """Each capsule's front point (N, 3): the point of its circle nearest ``position`` (the camera's, m), at the
    camera's height.

    Args:
        capsules: (N, 3) x, y and radius (m).
        position: (3,) the camera's world position (m).
    """
    capsules = np.asarray(capsules, np.float64).reshape(-1, 3)
    position = np.asarray(position, np.float64)
    towards = capsules[:, :2] - position[:2]
    towards /= np.maximum(np.linalg.norm(towards, axis=1, keepdims=True), 1e-9)
    return np.column_stack(
        [capsules[:, :2] - capsules[:, 2:3] * towards, np.full(len(capsules), position[2])]
    )


def histogram_cells(
    front: np.ndarray,
    position: np.ndarray,
    rotation: np.ndarray,
    fx: float,
    cx: float,
    width: int,
    sector_columns: int,
    bin_edges: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The histogram cell each front point (N, 3) falls in: its sector column and depth bin (clamped as the module
    docstring says), and whether it lay inside the image. Arguments as :func:`resolved_capsules`'s.

    Raises:
        ValueError: ``sector_columns`` < 1 or fewer than two ``bin_edges``.
    """
    if not sector_columns >= 1:
        raise ValueError(f"sector_columns must be >= 1, got {sector_columns!r}")
    edges = np.asarray(bin_edges, np.float64).reshape(-1)
    if len(edges) < 2:
        raise ValueError(f"bin_edges must hold at least two edges, got {len(edges)}")
    in_camera = (np.asarray(front, np.float64).reshape(-1, 3) - position) @ rotation  # rows: R^T (p - c)
    depth = in_camera[:, 2]
    ahead = depth > 1e-9
    # A front point at or behind the image plane lies beyond the edge on its own side.
    beyond = np.where(in_camera[:, 0] < 0.0, -1.0, float(width))
    column = np.where(ahead, fx * in_camera[:, 0] / np.where(ahead, depth, 1.0) + cx, beyond)
    inside = ahead & (column >= -0.5) & (column < width - 0.5)
    sector = np.clip(np.floor((column + 0.5) / (width / sector_columns)), 0, sector_columns - 1).astype(int)
    bins = np.clip(np.searchsorted(edges, depth, side="right") - 1, 0, len(edges) - 2)
    return sector, bins, inside


def centres_behind(front: np.ndarray, radii: np.ndarray, position: np.ndarray) -> np.ndarray:
    """The centres (N, 2) of capsules of ``radii`` whose front points seen from ``position`` are ``front``."""
    away = np.asarray(front, np.float64)[:, :2] - np.asarray(position, np.float64)[:2]
    away /= np.maximum(np.linalg.norm(away, axis=1, keepdims=True), 1e-9)
    return np.asarray(front, np.float64)[:, :2] + np.asarray(radii, np.float64).reshape(-1, 1) * away


def cell_points(
    sector: np.ndarray,
    bins: np.ndarray,
    position: np.ndarray,
    rotation: np.ndarray,
    fx: float,
    cx: float,
    width: int,
    sector_columns: int,
    bin_edges: np.ndarray,
    across: np.ndarray,
    deep: np.ndarray,
) -> np.ndarray:
    """World points (N, 3) in histogram cells: for each (sector, bin), the point at fraction ``across`` of the
    sector's pixel columns and ``deep`` of the bin's depths (0.5 and 0.5: the cell's centre)."""
    edges = np.asarray(bin_edges, np.float64).reshape(-1)
    sector_width = width / sector_columns
    column = (np.asarray(sector) + np.asarray(across)) * sector_width - 0.5
    depth = edges[bins] + np.asarray(deep) * (edges[np.asarray(bins) + 1] - edges[bins])
    ray = np.column_stack([(column - cx) / fx, np.zeros(len(column)), np.ones(len(column))])
    return position + (ray * depth[:, None]) @ np.asarray(rotation, np.float64).T


def resolved_capsules(
    capsules: np.ndarray,
    position: np.ndarray,
    rotation: np.ndarray,
    fx: float,
    cx: float,
    width: int,
    sector_columns: int,
    bin_edges: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Where the histogram puts each of ``capsules`` (N, 3): the capsule (x, y, radius) whose front point lies at
    its front point's sector-column centre and depth-bin centre (module docstring), and whether that front
    point lay inside the image (else it was clamped to the edge sector).

    Args:
        capsules: (N, 3) the seen capsules' true x, y and radius (m).
        position: (3,) the camera's world position (m); rotation: (3, 3) world-from-camera, OpenCV axes.
        fx, cx, width: the horizontal intrinsics (px).
        sector_columns: the histogram's sector columns across the image.
        bin_edges: the histogram's depth bin edges (m), at least two, increasing.

    Raises:
        ValueError: ``sector_columns`` < 1 or fewer than two ``bin_edges``.
    """
    capsules = np.asarray(capsules, np.float64).reshape(-1, 3)
    position = np.asarray(position, np.float64)
    rotation = np.asarray(rotation, np.float64)
    camera = (position, rotation, fx, cx, width, sector_columns, bin_edges)
    sector, bins, inside = histogram_cells(front_points(capsules, position), *camera)
    half = np.full(len(capsules), 0.5)
    resolved_front = cell_points(sector, bins, *camera, half, half)
    centres = centres_behind(resolved_front, capsules[:, 2], position)
    return np.column_stack([centres, capsules[:, 2]]), inside
