"""The teacher start (``imitation:`` in a training config): DAgger against a rule on the run's envs, recorded
in the run's record; bad settings fail in one line naming the key."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from helpers import teacher_started_record, tiny_train_config

from agents.common.yaml_config import ConfigError
from agents.policies.teachers import check_teacher, make_teacher
from agents.training.envs import build_envs, close_quietly
from agents.training.imitation import discounted_returns, fit, fly
from agents.training.outputs import RunFiles
from agents.training.ppo import new_model, train
from agents.training.run_record import interrupted_at
from agents.training.train_config import ImitationParams

TEACHER_ENV = {"observe_unresolved": True}


def test_discounted_returns_stop_at_each_episode_end() -> None:
    rewards = np.array([[1.0, 0.0], [1.0, 2.0], [1.0, 0.0]])
    dones = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    returns = discounted_returns(rewards, dones, gamma=0.5)
    # column 0: episode of steps 0-1 (1 + 0.5 * 1), then a cut episode at step 2
    # column 1: one episode 0, 2, 0 -> from step 0: 0 + 0.5 * 2 + 0.25 * 0
    np.testing.assert_allclose(returns, [[1.5, 1.0], [1.0, 2.0], [1.0, 0.0]])


def test_a_gamma_outside_0_1_is_refused() -> None:
    with pytest.raises(ValueError, match=r"gamma must be in \[0, 1\], got 1.5"):
        discounted_returns(np.zeros((2, 1)), np.zeros((2, 1)), gamma=1.5)


def test_the_student_learns_to_act_as_the_teacher(tmp_path: Path) -> None:
    config, _ = tiny_train_config(tmp_path, total=64, env={**_small_env(), **TEACHER_ENV})
    envs, eval_env = build_envs(config, in_process=True)
    teacher = make_teacher("bee_ttc")
    params = ImitationParams(teacher="bee_ttc", epochs=30, learning_rate=3e-3)
    try:
        model = new_model(config, envs)
        flights = fly(envs, teacher, steps=60, gamma=0.99)
        assert len(flights) == 60 and flights.teacher_actions.shape == (60, 3)
        assert set(flights.observations) >= {"depth_histogram", "state", "unresolved"}
        before = _action_error(model, flights)
        fit(model, flights, params, np.random.default_rng(0))
        after = _action_error(model, flights)
        assert after < 0.5 * before
        # DAgger's later rounds fly the student and still label every state with the teacher's action
        student_flights = fly(envs, teacher, steps=20, gamma=0.99, student=model)
        relabelled, _ = teacher.predict(
            {k: v[:1] for k, v in student_flights.observations.items()}, episode_start=np.ones(1, bool)
        )
        np.testing.assert_allclose(
            student_flights.teacher_actions[0], np.clip(relabelled[0], -1, 1), atol=1e-6
        )
    finally:
        close_quietly(envs)
        close_quietly(eval_env)


def test_a_run_with_a_teacher_imitates_it_first_and_records_it(tmp_path: Path) -> None:
    imitation = {"teacher": "bee_ttc", "rounds": 2, "steps_per_round": 16, "epochs": 2}
    _, record_path = teacher_started_record(tmp_path, imitation, env={**_small_env(), **TEACHER_ENV})
    record = json.loads(record_path.read_text())
    summary = record["sessions"][-1]["imitation"]
    assert summary["teacher"] == "bee_ttc" and summary["env_steps"] == 32
    assert [r["states"] for r in summary["rounds"]] == [16, 32]
    assert record["total_timesteps"] >= 64


def test_a_run_with_a_teacher_but_nothing_to_build_it_is_refused(tmp_path: Path) -> None:
    imitation = {"teacher": "bee_ttc", "rounds": 1, "steps_per_round": 8}
    config, config_path = tiny_train_config(
        tmp_path, total=64, env={**_small_env(), **TEACHER_ENV}, imitation=imitation
    )
    with pytest.raises(ValueError, match=r"names the teacher 'bee_ttc', but no make_teacher was given"):
        train(config, config_path=config_path, resume=False, runs_dir=tmp_path / "runs", progress_bar=False)


def test_a_teacher_with_init_from_is_refused_naming_the_keys(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"'imitation.teacher' \('bee_ttc'\) .* takes no 'init_from'"):
        tiny_train_config(tmp_path, total=64, imitation={"teacher": "bee_ttc"}, init_from="a/seed_{seed}.zip")


def test_an_unknown_teacher_is_refused_naming_the_allowed_ones() -> None:
    with pytest.raises(
        ValueError, match=r"run.yaml: key 'imitation.teacher' must be one of straight, .*got 'ppo_flow'"
    ):
        check_teacher("ppo_flow", TEACHER_ENV, "run.yaml")


def test_a_teacher_whose_keys_the_env_lacks_is_refused_naming_the_setting() -> None:
    with pytest.raises(ValueError, match=r"run.yaml: the teacher 'bee_ttc' reads .* observe_unresolved=True"):
        check_teacher("bee_ttc", {"observe_approach": True}, "run.yaml")
    check_teacher("bee_ttc", TEACHER_ENV, "run.yaml")
    check_teacher("bee", {}, "run.yaml")


def _small_env() -> dict:
    from helpers import SMALL

    return dict(SMALL)


def _action_error(model, flights) -> float:
    actions = model.predict(flights.observations, deterministic=True)[0]
    return float(np.mean((actions - flights.teacher_actions) ** 2))


class _StoppedTeacher:
    """bee_ttc until its ``calls``-th action, when Ctrl-C lands."""

    def __init__(self, calls: int) -> None:
        self.teacher, self.left = make_teacher("bee_ttc"), calls

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        self.left -= 1
        if self.left == 0:
            raise KeyboardInterrupt
        return self.teacher.predict(observation, state, episode_start, deterministic)


def test_an_interrupted_teacher_start_is_recorded_and_the_same_command_starts_afresh(tmp_path: Path) -> None:
    imitation = {"teacher": "bee_ttc", "rounds": 2, "steps_per_round": 8, "epochs": 1}
    config, config_path = tiny_train_config(
        tmp_path, total=64, env={**_small_env(), **TEACHER_ENV}, imitation=imitation
    )
    arguments = {
        "config_path": config_path,
        "resume": True,
        "runs_dir": tmp_path / "runs",
        "progress_bar": False,
    }
    with pytest.raises(KeyboardInterrupt):
        train(config, make_teacher=lambda name, params: _StoppedTeacher(5), **arguments)
    files = RunFiles.of(tmp_path / "runs", config.name)
    assert interrupted_at(files) == 0
    train(config, make_teacher=make_teacher, **arguments)
    record = json.loads(files.record.read_text())
    assert [s["status"] for s in record["sessions"]] == ["interrupted", "finished"]
    assert record["sessions"][-1]["imitation"]["env_steps"] == 16 and record["total_timesteps"] >= 64
