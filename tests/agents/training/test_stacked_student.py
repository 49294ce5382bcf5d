"""A DAgger student with memory (``frame_stack`` with an ``imitation`` teacher): the student acts on and is fitted
to stacks of its last frames, the teacher labels the current frame with its privileged keys, and the saved
policy flies with its stack; a teacher over stacks with no frame of its own to read is refused in one line."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from helpers import SMALL, teacher_started_record, tiny_train_config
from stable_baselines3.common.vec_env import DummyVecEnv, VecFrameStack

import flownav_env  # noqa: F401  (registers the env ids)
from agents.common.yaml_config import ConfigError
from agents.policies.loading import load_policy_file
from agents.policies.stacked import FrameStackedAgent, stacked_space
from agents.policies.teachers import PlannerTeacher
from agents.training.envs import build_envs, close_quietly
from agents.training.imitation import fly
from agents.training.outputs import RunFiles
from agents.training.ppo import new_model
from agents.training.student_view import StudentView, privileged_settings, teacher_view
from flownav_env.privileged import PRIVILEGED_KEYS

STACK = 2
CAMERA_TEACHER = {"teacher": "planner_camera", "rounds": 2, "steps_per_round": 8, "epochs": 1}


class _RecordingCameraTeacher(PlannerTeacher):
    """The camera-limited planner teacher, keeping a copy of every observation it was given."""

    def __init__(self) -> None:
        super().__init__(name="planner_camera")
        self.observations: list[dict[str, np.ndarray]] = []

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        self.observations.append({key: np.array(value) for key, value in observation.items()})
        return super().predict(observation, state, episode_start, deterministic)


def _single_frame_space() -> gym.spaces.Dict:
    env = gym.make("FlowNavSingle-v0", **SMALL)
    try:
        return env.observation_space
    finally:
        env.close()


def test_the_student_sees_stacks_while_the_teacher_reads_the_current_frame(tmp_path: Path) -> None:
    config, _ = tiny_train_config(tmp_path, total=64, imitation=CAMERA_TEACHER, frame_stack=STACK)
    single = _single_frame_space()
    teacher = _RecordingCameraTeacher()
    envs, eval_env = build_envs(config, in_process=True, teacher_settings=privileged_settings(teacher))
    try:
        model = new_model(config, envs)
        expected = stacked_space(single, STACK)
        for space in (envs.observation_space, eval_env.observation_space, model.observation_space):
            assert space == expected and space["state"].shape == (STACK * single["state"].shape[0],)
        flights = fly(envs, teacher, steps=10, gamma=0.99, student=model)
        assert len(flights) == 10 and len(teacher.observations) == 10
        assert {key: value.shape[1:] for key, value in flights.observations.items()} == {
            key: space.shape for key, space in expected.spaces.items()
        }
        for step, seen in enumerate(teacher.observations):
            assert set(PRIVILEGED_KEYS) <= set(seen)
            for key, space in single.spaces.items():
                # The teacher's frame is the newest of the student's stack (stacked along the last axis).
                assert seen[key].shape == (1, *space.shape)
                width = space.shape[-1]
                np.testing.assert_array_equal(flights.observations[key][step][..., -width:], seen[key][0])
        assert not set(flights.observations) & set(PRIVILEGED_KEYS)
        assert float(abs(flights.teacher_actions).max()) > 0.0  # the planner acted, not a stub's zeros
    finally:
        close_quietly(envs)
        close_quietly(eval_env)


def test_a_stacked_dagger_student_is_saved_and_flies_with_its_stack(tmp_path: Path) -> None:
    config, record = teacher_started_record(tmp_path, CAMERA_TEACHER, frame_stack=STACK)
    summary = json.loads(record.read_text())["sessions"][-1]["imitation"]
    assert summary["teacher"] == "planner_camera" and [r["states"] for r in summary["rounds"]] == [8, 16]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a fresh run's folder has no manifest
        agent = load_policy_file(RunFiles.of(tmp_path / "runs", config.name).policy)
    assert isinstance(agent, FrameStackedAgent) and agent.frame_stack == STACK
    env = gym.make("FlowNavSingle-v0", **SMALL)
    try:
        observation, _ = env.reset(seed=3)
        action, stack = agent.predict(observation, episode_start=np.ones(1, bool))
        for _ in range(3):
            assert env.action_space.contains(np.asarray(action, np.float32))
            observation, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                break
            action, stack = agent.predict(observation, state=stack, episode_start=np.zeros(1, bool))
    finally:
        env.close()


def test_a_teacher_over_stacks_without_a_student_view_is_refused() -> None:
    envs = VecFrameStack(DummyVecEnv([lambda: gym.make("FlowNavSingle-v0", **SMALL)]), STACK)
    try:
        with pytest.raises(
            ValueError,
            match=r"^a teacher reads one frame, but these envs stack 2 frames over no StudentView to read the "
            r"current frame from: wrap the envs in StudentView beneath VecFrameStack$",
        ):
            teacher_view(envs, envs.reset())
        viewed = VecFrameStack(StudentView(envs.venv), STACK)
        stacked = viewed.reset()
        assert teacher_view(viewed, stacked)["state"].shape == (1, stacked["state"].shape[1] // STACK)
    finally:
        envs.close()


def test_a_teacher_with_frame_stacking_is_allowed_and_with_an_lstm_refused(tmp_path: Path) -> None:
    config, _ = tiny_train_config(tmp_path, total=64, imitation={"teacher": "bee"}, frame_stack=4)
    assert config.frame_stack == 4 and config.imitation.teacher == "bee"
    with pytest.raises(
        ConfigError,
        match=r"key 'imitation.teacher' \('bee'\) starts a feed-forward policy from scratch: it takes no "
        r"'init_from' or 'ppo.lstm_hidden_size' above 0 \(for memory, use 'frame_stack'\)$",
    ):
        tiny_train_config(
            tmp_path, total=64, name="lstm", imitation={"teacher": "bee"}, ppo={"lstm_hidden_size": 8}
        )
