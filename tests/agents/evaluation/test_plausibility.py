"""An episode is recorded only if the physics could have flown it: a drone moved by writing into the simulator
(as an agent with the scorer's memory in reach could) is refused in one line, and honest flights pass."""

from __future__ import annotations

import dataclasses
import math

import gymnasium as gym
import pytest
from helpers import SMALL

from agents.analysis.episode_record import EpisodeRecord
from agents.evaluation.episode import run_episode
from agents.evaluation.plausibility import implausibility, speed_bound
from agents.policies import StraightAgent
from flownav_env.settings import EnvSettings

SETTINGS = EnvSettings()


class Teleporter(StraightAgent):
    """Writes the drone's position into MuJoCo's data at its third step, as the ``/proc/<pid>/mem`` attack did."""

    def __init__(self, env: gym.Env, x: float) -> None:
        super().__init__()
        self.env, self.x, self.calls = env, x, 0

    def predict(self, observation, state=None, episode_start=None, deterministic=True):  # type: ignore[no-untyped-def]
        self.calls += 1
        if self.calls == 3:
            self.env.unwrapped.physics.data.qpos[0] = self.x
        return super().predict(observation, state, episode_start, deterministic)


def test_a_drone_moved_by_writing_into_the_simulator_is_not_recorded() -> None:
    env = gym.make("FlowNav-v1", max_episode_steps=6, **SMALL)
    try:
        with pytest.raises(ValueError) as raised:
            run_episode(env, Teleporter(env, 20.5), seed=3, label="teleporter")
    finally:
        env.close()
    message = str(raised.value)
    assert message.startswith(
        "agent 'teleporter' on FlowNav-v1 (clean), layout 3: not a flight the physics allows"
    )
    assert "faster than the 3.00 m/s it can fly); nothing was recorded of it" in message


def test_an_honest_flight_is_plausible() -> None:
    env = gym.make("FlowNav-v1", max_episode_steps=6, **SMALL)
    try:
        record = run_episode(env, StraightAgent(), seed=3)
    finally:
        env.close()
    assert record.steps == 6


def _record(**changes: object) -> EpisodeRecord:
    flown = EpisodeRecord(
        "a", "clean", 0.0, 1, False, True, False, False, 20.1, 20.1, 201, 0.3, 20.6, 100.0, 0.05, 28.0
    )
    return dataclasses.replace(flown, **changes)


def test_the_checks_name_what_cannot_have_been_flown() -> None:
    bound = speed_bound(SETTINGS)
    assert bound == pytest.approx(2.0 * math.hypot(1.0, 1.0, 0.5))
    assert implausibility(_record(), SETTINGS, fastest_step_m=0.12) == ""
    assert implausibility(_record(time_s=5.0), SETTINGS, 0.12) == "201 steps at 10 Hz are not its 5 s"
    assert implausibility(_record(progress_m=80.0), SETTINGS, 0.12) == (
        f"80.00 m of progress in 20.1 s is faster than {bound:.2f} m/s"
    )
    assert implausibility(_record(path_length_m=90.0), SETTINGS, 0.12).startswith(
        "a path of 90.00 m in 20.1 s"
    )
    assert implausibility(_record(), SETTINGS, fastest_step_m=1.0).startswith(
        "the drone moved 1.00 m in one frame"
    )
