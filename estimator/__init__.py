"""Optical-flow depth estimation for small drones (the thesis's estimator).

FAST keypoints → pyramidal Lucas-Kanade flow → rotation compensation from the known rotation → depth from the
known translation, plus the sector histogram that turns the depth points into a fixed-size observation.
numpy and OpenCV only: no MuJoCo, Gymnasium or torch here.

Public API:
    :class:`CameraIntrinsics`, :class:`FlowDepthEstimator`, :class:`DepthPoints`, :func:`sector_histogram`,
    :func:`sector_fraction`, :data:`DEFAULT_BIN_EDGES`. The evaluation on RGB-D sequences is in :mod:`estimator.accuracy`.
"""

from importlib.metadata import PackageNotFoundError, version

from estimator.camera import CameraIntrinsics
from estimator.estimator import FlowDepthEstimator
from estimator.histogram import (
    DEFAULT_BIN_EDGES,
    DEFAULT_SECTORS,
    sector_counts,
    sector_fraction,
    sector_histogram,
    sector_near_depth,
)
from estimator.points import DepthPoints

try:
    # The one version of the flownav distribution (estimator, flownav_env and agents), from pyproject.toml.
    __version__ = version("flownav")
except PackageNotFoundError:  # a source tree that was never installed
    __version__ = "unknown"

__all__ = [
    "DEFAULT_BIN_EDGES",
    "DEFAULT_SECTORS",
    "CameraIntrinsics",
    "DepthPoints",
    "FlowDepthEstimator",
    "__version__",
    "sector_counts",
    "sector_fraction",
    "sector_histogram",
    "sector_near_depth",
]
