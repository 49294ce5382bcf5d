"""A teacher start from the privileged planner: the training envs observe the layout for the teacher alone, the
student's policy never sees a privileged key, and the saved config asks a tier for nothing privileged."""

from __future__ import annotations

import json
from pathlib import Path
from typing import ClassVar

import numpy as np
import pytest
from helpers import SMALL, teacher_started_record, tiny_train_config

from agents.common.yaml_config import ConfigError, load_config
from agents.policies.learned import agent_env_kwargs
from agents.policies.teachers import PlannerTeacher, check_teacher, make_teacher
from agents.training.envs import build_envs, close_quietly
from agents.training.imitation import fly
from agents.training.outputs import RunFiles
from agents.training.ppo import new_model
from agents.training.student_view import StudentView, privileged_settings, teacher_view
from agents.training.train_config import TrainConfig
from flownav_env.privileged import PRIVILEGED_KEYS
from flownav_env.tiers import TIER_NAMES, check_agent_settings, privileged_requests

PLANNER_STUDENT_CONFIG = Path("configs/experiments/ppo_flow_planner_student.yaml")


class _RecordingTeacher(PlannerTeacher):
    """The planner teacher, keeping the keys of every observation it was given."""

    def __init__(self) -> None:
        super().__init__()
        self.seen: set[str] = set()

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        self.seen |= set(observation)
        return super().predict(observation, state, episode_start, deterministic)


def test_the_student_sees_no_privileged_key_while_the_planner_reads_them(tmp_path: Path) -> None:
    config, _ = tiny_train_config(tmp_path, total=64, imitation={"teacher": "planner"})
    teacher = _RecordingTeacher()
    envs, eval_env = build_envs(config, in_process=True, teacher_settings=privileged_settings(teacher))
    try:
        assert isinstance(envs, StudentView) and isinstance(eval_env, StudentView)
        model = new_model(config, envs)
        for space in (envs.observation_space, eval_env.observation_space, model.observation_space):
            assert not set(space.spaces) & set(PRIVILEGED_KEYS)
        flights = fly(envs, teacher, steps=12, gamma=0.99, student=model)
        assert set(PRIVILEGED_KEYS) <= teacher.seen
        assert not set(flights.observations) & set(PRIVILEGED_KEYS) and len(flights) == 12
        assert set(PRIVILEGED_KEYS) <= set(teacher_view(envs, envs.reset()))
    finally:
        close_quietly(envs)
        close_quietly(eval_env)


def test_a_planner_taught_run_records_the_teacher_and_ships_an_ordinary_config(tmp_path: Path) -> None:
    imitation = {"teacher": "planner", "rounds": 2, "steps_per_round": 8, "epochs": 1}
    config, record = teacher_started_record(tmp_path, imitation)
    files = RunFiles.of(tmp_path / "runs", config.name)
    summary = json.loads(record.read_text())["sessions"][-1]["imitation"]
    assert summary["teacher"] == "planner" and summary["teacher_env"] == {"observe_layout": True}
    assert [r["states"] for r in summary["rounds"]] == [8, 16]
    # The saved env is the student's own: nothing privileged; past the test's small camera, what any tier allows.
    saved = agent_env_kwargs("ppo_flow", files.policy)  # what evaluation flies the run's policy with
    assert saved == load_config(files.config, TrainConfig).env
    assert privileged_requests(saved) == {}
    for tier_name in TIER_NAMES:
        check_agent_settings("student", {k: v for k, v in saved.items() if k not in SMALL}, tier_name)


def test_the_shipped_recipe_asks_no_tier_for_privileged_data() -> None:
    config = load_config(PLANNER_STUDENT_CONFIG, TrainConfig)
    assert config.imitation.teacher == "planner"
    check_teacher(config.imitation.teacher, config.env, str(PLANNER_STUDENT_CONFIG))
    for tier_name in TIER_NAMES:
        check_agent_settings(config.name, config.env, tier_name)


def test_a_privileged_teacher_whose_keys_would_reach_the_student_is_refused(tmp_path: Path) -> None:
    with pytest.raises(
        ConfigError, match=r"'env.observe_layout' would show the student of teacher 'planner'"
    ):
        tiny_train_config(
            tmp_path, total=64, env={**SMALL, "observe_layout": True}, imitation={"teacher": "planner"}
        )


def test_the_planner_teaches_without_asking_the_env_section_for_its_keys() -> None:
    check_teacher("planner", {}, "run.yaml")
    with pytest.raises(ValueError, match=r"run.yaml: key 'imitation.teacher' must be one of .*planner"):
        check_teacher("ppo_oracle", {}, "run.yaml")


def test_the_planner_teacher_flies_the_parameters_a_config_gives_it() -> None:
    teacher = make_teacher("planner", {"soft_clearance": 0.8, "hard_margin": 0.15})
    assert isinstance(teacher, PlannerTeacher)
    assert teacher.params == {"soft_clearance": 0.8, "hard_margin": 0.15}
    check_teacher("planner", {}, "run.yaml", {"clearance_weight": 4.0})


@pytest.mark.parametrize(
    ("name", "params", "message"),
    [
        (
            "planner",
            {"margin": 0.2},
            r"run.yaml: key 'imitation.teacher_params.margin' is not a parameter "
            r"of planner; allowed: hard_margin, soft_clearance",
        ),
        (
            "planner",
            {"soft_clearance": "wide"},
            r"'imitation.teacher_params.soft_clearance' must be a number, "
            r"got 'wide'",
        ),
        (
            "planner",
            {"hard_margin": -0.1},
            r"run.yaml: key 'imitation.teacher_params': hard_margin must be > 0, "
            r"got -0.1",
        ),
        ("planner", {"commands": 9.5}, r"'imitation.teacher_params.commands' must be an integer, got 9.5"),
        (
            "bee_ttc",
            {"soft_clearance": 0.8},
            r"sets a planner teacher's parameters; 'bee_ttc' flies its shipped "
            r"gains and takes none, got \['soft_clearance'\]",
        ),
    ],
)
def test_teacher_parameters_that_are_not_the_planners_are_refused(name, params, message) -> None:
    env = agent_env_kwargs(name) if name != "planner" else {}
    with pytest.raises(ValueError, match=message):
        check_teacher(name, env, "run.yaml", params)


def test_a_teacher_declaring_another_privileged_setting_is_refused() -> None:
    class _OracleTeacher:
        privileged_settings: ClassVar[dict[str, str]] = {"obs_source": "oracle"}

    with pytest.raises(ValueError, match=r"may only be observe_layout .*got obs_source"):
        privileged_settings(_OracleTeacher())
    assert privileged_settings(make_teacher("bee")) == {}


def test_the_planner_teacher_plans_each_env_of_a_batch_apart() -> None:
    import gymnasium as gym

    import flownav_env  # noqa: F401  (registers the ids)

    envs = [gym.make("FlowNavSingle-v0", **SMALL, observe_layout=True) for _ in range(2)]
    try:
        observations = [env.reset(seed=seed)[0] for env, seed in zip(envs, (1, 2), strict=True)]
        batch = {key: np.stack([o[key] for o in observations]) for key in observations[0]}
        teacher = PlannerTeacher()
        actions, _ = teacher.predict(batch, episode_start=np.ones(2, bool))
        assert actions.shape == (2, 3) and len(teacher.planners) == 2
        alone, _ = make_teacher("planner").predict(
            {key: value[1:] for key, value in batch.items()}, episode_start=np.ones(1, bool)
        )
        np.testing.assert_allclose(actions[1], alone[0])
    finally:
        for env in envs:
            env.close()


def test_a_student_view_of_an_env_without_dict_observations_is_refused() -> None:
    import gymnasium as gym
    from stable_baselines3.common.vec_env import DummyVecEnv

    envs = DummyVecEnv([lambda: gym.make("Pendulum-v1")])
    with pytest.raises(ValueError, match=r"StudentView needs a dict observation space, got Box"):
        StudentView(envs)
