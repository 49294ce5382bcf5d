"""Wall-clock seconds a :class:`~flownav_env.env.FlowNavEnv` spends in each stage of its steps, for speed
benchmarks (:meth:`FlowNavEnv.time_stages`).

The stages are the env's own collaborators, timed around their calls: ``physics`` (the controller and MuJoCo's
substeps, ``FlowNavPhysics.advance``), ``render`` (the onboard camera's frame), ``estimator``
(``FlowDepthEstimator.update``) and ``ground_truth`` (the ray cast of true depths, ``FlowNavPhysics.ray_depths``).
What a step spends outside them (sensor model, histogram, reward, wrappers) is the step's time less their sum.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import ParamSpec, TypeVar

STAGES = ("physics", "render", "estimator", "ground_truth")

_P = ParamSpec("_P")
_R = TypeVar("_R")


class StageTimes:
    """Seconds spent in each of :data:`STAGES`, summed since timing started.

    The totals only grow: a caller that wants one step's split reads :meth:`snapshot` before and after it.
    """

    def __init__(self) -> None:
        self._seconds = dict.fromkeys(STAGES, 0.0)

    def snapshot(self) -> dict[str, float]:
        """A copy of the totals so far, by stage, in seconds."""
        return dict(self._seconds)

    def timed(self, stage: str, function: Callable[_P, _R]) -> Callable[_P, _R]:
        """``function`` with its wall time added to ``stage`` on every call (about 1 µs per call).

        Raises:
            ValueError: ``stage`` is not one of :data:`STAGES`.
        """
        if stage not in self._seconds:
            raise ValueError(f"stage must be one of {', '.join(STAGES)}, got {stage!r}")
        seconds = self._seconds

        def wrapper(*args: _P.args, **kwargs: _P.kwargs) -> _R:
            start = time.perf_counter()
            try:
                return function(*args, **kwargs)
            finally:
                seconds[stage] += time.perf_counter() - start

        return wrapper
