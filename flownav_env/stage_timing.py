"""Wall-clock seconds a :class:`~flownav_env.env.FlowNavEnv` spends in each stage of its steps, for speed
benchmarks (:meth:`FlowNavEnv.time_stages`).

The stages are the env's own collaborators, timed around their calls by the env's clock (a hook: ``step``
and ``reset`` wrap each call in ``with clock.stage(...)``; untimed until asked): ``physics`` (the controller and MuJoCo's
substeps, ``FlowNavPhysics.advance``), ``render`` (the onboard camera's frame), ``estimator``
(``FlowDepthEstimator.update``) and ``ground_truth`` (the ray cast of true depths, ``FlowNavPhysics.ray_depths``).
What a step spends outside them (sensor model, histogram, reward, wrappers) is the step's time less their sum.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import AbstractContextManager, contextmanager, nullcontext
from typing import Protocol

STAGES = ("physics", "render", "estimator", "ground_truth")


class StageClock(Protocol):
    """What the env's ``step`` and ``reset`` time their stages with: ``with clock.stage("render"): ...``."""

    def stage(self, name: str) -> AbstractContextManager[None]: ...


class Untimed:
    """The env's clock until :meth:`FlowNavEnv.time_stages`: every stage is an empty context (a few
    hundred ns)."""

    _nothing: AbstractContextManager[None] = nullcontext()

    def stage(self, name: str) -> AbstractContextManager[None]:
        return self._nothing


class StageTimes:
    """Seconds spent in each of :data:`STAGES`, summed since timing started.

    The totals only grow: a caller that wants one step's split reads :meth:`snapshot` before and after it.
    """

    def __init__(self) -> None:
        self._seconds = dict.fromkeys(STAGES, 0.0)

    def snapshot(self) -> dict[str, float]:
        """A copy of the totals so far, by stage, in seconds."""
        return dict(self._seconds)

    @contextmanager
    def stage(self, name: str) -> Iterator[None]:
        """Adds the wall time of the ``with`` block to the stage ``name`` (about 1 µs per block).

        Raises:
            ValueError: ``name`` is not one of :data:`STAGES`.
        """
        if name not in self._seconds:
            raise ValueError(f"stage must be one of {', '.join(STAGES)}, got {name!r}")
        start = time.perf_counter()
        try:
            yield
        finally:
            self._seconds[name] += time.perf_counter() - start
