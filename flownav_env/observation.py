"""What the FlowNav agent observes, assembled from the estimator's depth points and the drone's own state,
and the estimator statistics the env reports in ``info``. No simulation happens here.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, NotRequired, TypedDict

import numpy as np
from gymnasium import spaces

from estimator import DepthPoints
from estimator.accuracy import OUTLIER_RELATIVE_ERROR, relative_depth_error
from estimator.histogram import SectorGrid
from flownav_env.privileged import privileged_spaces
from flownav_env.settings import EnvSettings

if TYPE_CHECKING:
    from flownav_env.physics import FlowNavPhysics

# A sector's point count as a bounded confidence: 1 - exp(-n / COUNT_SCALE) is 0.63 at 10 points, 0.99 at 46.
COUNT_SCALE = 10.0
# A sector's near depth d as a nearness min(1, NEAR_DEPTH_M / d): 1 within half a metre, 0.1 at 5 m, 0 if empty.
NEAR_DEPTH_M = 0.5
# ... and as an approach min(1, NEAR_TIME_S · v / d) at forward speed v: 1 within half a second of contact. With
# NEAR_TIME_S · 1 m/s = NEAR_DEPTH_M the two agree at 1 m/s, the speed the env flies by default.
NEAR_TIME_S = 0.5
NEAR_KEYS = frozenset({"nearness", "approach"})

STATE_FIELDS = (
    "forward_velocity",
    "lateral_velocity",
    "vertical_velocity",
    "roll",
    "pitch",
    "height",
    "heading_error",
)
STATE_LOW = np.array([-5.0, -5.0, -5.0, -math.pi, -math.pi / 2, 0.0, -math.pi], np.float32)
STATE_HIGH = np.array([5.0, 5.0, 5.0, math.pi, math.pi / 2, 10.0, math.pi], np.float32)


def observation_space(settings: EnvSettings) -> spaces.Dict:
    """The ``Dict`` space of the observations these settings produce."""
    rows, cols = settings.histogram_sectors
    boxes: dict[str, spaces.Space[Any]] = {
        "depth_histogram": spaces.Box(0.0, 1.0, (rows, cols, len(settings.depth_bin_edges) - 1), np.float32),
        "state": spaces.Box(STATE_LOW, STATE_HIGH, dtype=np.float32),
    }
    if settings.observe_unresolved:
        boxes["unresolved"] = spaces.Box(0.0, 1.0, (rows, cols), np.float32)
    if settings.observe_counts:
        boxes["point_counts"] = spaces.Box(0.0, 1.0, (rows, cols), np.float32)
    if settings.observe_nearness:
        boxes["nearness"] = spaces.Box(0.0, 1.0, (rows, cols), np.float32)
    if settings.observe_approach:
        boxes["approach"] = spaces.Box(0.0, 1.0, (rows, cols), np.float32)
    if settings.observe_layout:
        boxes.update(privileged_spaces(settings))
    return spaces.Dict(boxes)


def observed_depths(
    obs_source: str, points: DepthPoints, true_depth: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The depths the histogram counts and which points count, for each ``obs_source``.

    The oracles keep the estimator's tracked points but swap in their true depths, so that comparing them
    with ``"flow"`` separates the estimator's choice of points from its measurement of them.
    """
    if obs_source == "oracle":
        # The same points the estimator tracked, with their true depth (parallax or not).
        return true_depth, points.tracked & np.isfinite(true_depth)
    if obs_source == "oracle_valid":
        return true_depth, points.valid & np.isfinite(true_depth)
    return points.depth, points.valid


def assemble_observation(
    settings: EnvSettings,
    grid: SectorGrid,
    state: np.ndarray,
    points: DepthPoints,
    depth: np.ndarray,
    counted: np.ndarray,
) -> dict[str, np.ndarray]:
    """The observation dict of the ``counted`` points (depths ``depth``): ``depth_histogram`` and ``state``;
    ``unresolved`` (tracked points left uncounted, per sector), ``point_counts`` (how many points a sector's
    histogram counts, as ``1 - exp(-n / COUNT_SCALE)``), ``nearness`` and ``approach`` (a sector's robust near
    depth over a distance, and over the distance flown in :data:`NEAR_TIME_S`) only when asked for. The
    points' sectors are found once (``grid``: the env's sectors and bins) and shared by every key."""
    sector = grid.locate(points.points)
    observation = {"depth_histogram": grid.histogram(sector, depth, counted), "state": state}
    if settings.observe_unresolved:
        observation["unresolved"] = grid.fraction(sector, points.tracked & ~counted, points.tracked)
    if settings.observe_counts:
        counts = grid.counts(sector, counted)
        observation["point_counts"] = (1.0 - np.exp(-counts / COUNT_SCALE)).astype(np.float32)
    if settings.observe_nearness or settings.observe_approach:
        near = grid.near_depth(sector, depth, counted)
        if settings.observe_nearness:
            observation["nearness"] = np.minimum(1.0, NEAR_DEPTH_M / near).astype(np.float32)
        if settings.observe_approach:
            forward_speed = max(float(state[0]), 0.0)
            # The floor keeps a zero depth at hover from giving 0 / 0.
            approach = NEAR_TIME_S * forward_speed / np.maximum(near, 1e-6)
            observation["approach"] = np.minimum(1.0, approach).astype(np.float32)
    return observation


def exponential_average(newest: np.ndarray, average: np.ndarray, weight: float) -> np.ndarray:
    """One step of an exponential average over frames: ``weight`` · ``newest`` + (1 − ``weight``) · ``average``."""
    return weight * newest + (1.0 - weight) * average


def smoothed_near(
    observation: dict[str, np.ndarray], previous: dict[str, np.ndarray] | None, weight: float
) -> dict[str, np.ndarray]:
    """A copy of ``observation`` with its ``nearness`` and ``approach`` (where present) averaged over frames
    (:func:`exponential_average` with ``previous``'s average); ``observation`` itself on an episode's first
    frame (``previous`` None) or with ``weight`` 1. A sector keeps a near surface for a few frames after the
    estimator loses its points, as ``bee_robust``'s own smoothing does."""
    if previous is None or weight >= 1.0:
        return observation
    return {
        key: exponential_average(value, previous[key], weight).astype(np.float32)
        if key in NEAR_KEYS
        else value
        for key, value in observation.items()
    }


def drone_state(physics: FlowNavPhysics) -> np.ndarray:
    """The ``state`` observation: what a real drone knows of itself, clipped to the space's bounds."""
    yaw = physics.yaw()
    cos_yaw, sin_yaw = math.cos(yaw), math.sin(yaw)
    vx, vy, vz = physics.velocity_world()
    roll, pitch = physics.roll_pitch()
    state = np.array(
        [
            cos_yaw * vx + sin_yaw * vy,
            -sin_yaw * vx + cos_yaw * vy,
            vz,
            roll,
            pitch,
            physics.position()[2],
            math.atan2(math.sin(yaw), math.cos(yaw)),
        ],
        np.float32,
    )
    return np.clip(state, STATE_LOW, STATE_HIGH)


class EstimatorInfo(TypedDict):
    """The estimator's entries of a step's ``info``: keypoints tracked and with a valid depth, and, where some
    valid point had a finite true depth, the median relative depth error and the share of outliers."""

    points_tracked: int
    points_valid: int
    depth_error_median: NotRequired[float]
    depth_outlier_share: NotRequired[float]


def estimator_info(points: DepthPoints, true_depth: np.ndarray) -> EstimatorInfo:
    """Estimator statistics; ``depth_error_median`` and ``depth_outlier_share`` (share of those points off by
    more than ``OUTLIER_RELATIVE_ERROR`` of their true depth) only when some valid point has a finite ground
    truth (a reset frame has no truth yet, so it passes an empty ``true_depth``)."""
    valid = np.asarray(points.valid, bool)
    comparable = valid & np.isfinite(true_depth) if len(true_depth) == len(valid) else np.zeros_like(valid)
    info: EstimatorInfo = {"points_tracked": len(valid), "points_valid": int(valid.sum())}
    if comparable.any():
        relative = relative_depth_error(points.depth[comparable], true_depth[comparable])
        info["depth_error_median"] = float(np.median(relative))
        info["depth_outlier_share"] = float(np.mean(relative > OUTLIER_RELATIVE_ERROR))
    return info
