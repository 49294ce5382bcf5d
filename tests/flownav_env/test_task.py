"""flownav_env.task and the env's step: a step runs its stages in the order the data flows, with no
callback into the env, and the Task bins each frame's points once, its grid checked once, not every step."""

from __future__ import annotations

import math

import numpy as np
import pytest

import estimator.histogram
from estimator.histogram import SectorGrid
from flownav_env import FlowNavEnv
from flownav_env.settings import EnvSettings
from flownav_env.task import FlowNavTask, StepOutcome

SMALL = {"camera_width": 64, "camera_height": 48}
ALL_KEYS = {
    "observe_unresolved": True,
    "observe_counts": True,
    "observe_nearness": True,
    "observe_approach": True,
}


def _record(calls: list[str], name: str, function):
    def wrapper(*args, **kwargs):
        calls.append(name)
        return function(*args, **kwargs)

    return wrapper


def test_a_step_reads_top_to_bottom() -> None:
    env = FlowNavEnv(**SMALL, depth_noise=0.1)
    env.reset(seed=0)
    calls: list[str] = []
    # Instance attributes shadow the methods, as the benchmark's stage timers do.
    env.physics.advance = _record(calls, "advance the body", env.physics.advance)
    env._camera.render = _record(calls, "take a frame", env._camera.render)
    env._sensor.motion = _record(calls, "the told motion", env._sensor.motion)
    env.estimator.update = _record(calls, "estimate", env.estimator.update)
    env._sensor.corrupt_points = _record(calls, "corrupt", env._sensor.corrupt_points)
    env.physics.ray_depths = _record(calls, "true depth", env.physics.ray_depths)
    env.task.observe = _record(calls, "observe", env.task.observe)
    env.task.outcome = _record(calls, "end", env.task.outcome)
    env.task.reward = _record(calls, "reward", env.task.reward)
    env.step(np.zeros(3))
    assert calls == [
        "advance the body",
        "take a frame",
        "the told motion",
        "estimate",
        "corrupt",
        "true depth",
        "observe",
        "end",
        "reward",
    ]
    env.close()


def test_a_step_locates_the_points_once_and_checks_no_grid_argument(monkeypatch: pytest.MonkeyPatch) -> None:
    env = FlowNavEnv(**SMALL, **ALL_KEYS, near_smoothing=0.5)
    env.reset(seed=1)

    def checked_again(*args, **kwargs):
        raise AssertionError("the sector grid's arguments were checked on the hot path")

    for name in ("_as_pair", "_as_bin_edges", "_as_point_arrays"):
        monkeypatch.setattr(estimator.histogram, name, checked_again)
    located = []
    monkeypatch.setattr(SectorGrid, "locate", _record(located, "locate", SectorGrid.locate))
    for _ in range(3):
        observation, *_ = env.step(np.array([0.2, 0.0, 0.1]))
    assert len(located) == 3 and set(observation) == {
        "depth_histogram",
        "state",
        "unresolved",
        "point_counts",
        "nearness",
        "approach",
    }
    assert not env.task.grid.bin_edges.flags.writeable
    env.close()


def test_the_task_ends_and_rewards_an_outcome() -> None:
    settings = EnvSettings(clearance_weight=2.0, safe_clearance=0.5, control_cost_weight=0.1)
    crash = StepOutcome(True, False, False, np.array([3.0, 0.0, 1.0]), 0.1, 0.25, 0.25)
    terms = FlowNavTask.reward(settings, crash, np.array([1.0, 0.0, 0.0]))
    assert crash.terminated and crash.info()["progress"] == 3.0
    assert terms == {
        "reward_progress": pytest.approx(0.1),
        "reward_success": 0.0,
        "reward_collision": -10.0,
        "reward_control": pytest.approx(-0.1),
        "reward_clearance": pytest.approx(-1.0),
    }
    cruise = StepOutcome(False, False, False, np.array([1.0, 0.0, 1.0]), 0.1, math.inf, math.inf)
    assert (
        not cruise.terminated and FlowNavTask.reward(settings, cruise, np.zeros(3))["reward_clearance"] == 0.0
    )
