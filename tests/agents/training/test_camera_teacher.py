"""A teacher start from the camera-limited planner (``planner_camera``): it brings its own privileged opt-in, its
keys (the layout, the camera's pose, the histogram's bins) reach the teacher alone, and bad names or parameters
fail in one line naming the value."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from helpers import teacher_started_record, tiny_train_config

from agents.policies import agent_env_kwargs
from agents.policies.base import PLANNERS
from agents.policies.planner_camera import CAMERA_PLANNER_KEYS
from agents.policies.teachers import PlannerTeacher, check_teacher, make_teacher
from agents.training.envs import build_envs, close_quietly
from agents.training.imitation import fly
from agents.training.outputs import RunFiles
from agents.training.ppo import new_model
from agents.training.student_view import privileged_settings
from flownav_env.privileged import PRIVILEGED_KEYS


class _RecordingCameraTeacher(PlannerTeacher):
    """The camera-limited planner teacher, keeping the keys of every observation it was given."""

    def __init__(self) -> None:
        super().__init__(name="planner_camera")
        self.seen: set[str] = set()

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        self.seen |= set(observation)
        return super().predict(observation, state, episode_start, deterministic)


@pytest.mark.parametrize("name", PLANNERS)
def test_every_planner_teaches_with_its_own_privileged_settings(name: str) -> None:
    teacher = make_teacher(name)
    assert isinstance(teacher, PlannerTeacher) and teacher.name == name
    assert privileged_settings(teacher) == {"observe_layout": True}
    # A run's env holds the settings the teacher reads that any agent may ask for (a finer histogram), as YAML
    # writes them: lists.
    asked = {
        key: list(value) if isinstance(value, tuple) else value
        for key, value in agent_env_kwargs(name).items()
        if key != "observe_layout"
    }
    check_teacher(name, asked, "run.yaml")


def test_the_camera_planner_teaches_with_its_own_parameters() -> None:
    teacher = make_teacher("planner_camera", {"view_range": 1.5, "memory": False})
    assert isinstance(teacher, PlannerTeacher)
    assert teacher.params == {"view_range": 1.5, "memory": False}
    assert teacher.planner_class.__name__ == "CameraPlannerAgent"


@pytest.mark.parametrize(
    ("name", "params", "message"),
    [
        (
            "planner_camera",
            {"view_range": -1.0},
            r"run.yaml: key 'imitation.teacher_params': view_range must be a "
            r"finite distance > 0 \(m\), got -1.0",
        ),
        (
            "planner_camera",
            {"memory": 1},
            r"run.yaml: key 'imitation.teacher_params.memory' must be true or "
            r"false, got 1",
        ),
        (
            "planner_camera",
            {"range": 2.0},
            r"run.yaml: key 'imitation.teacher_params.range' is not a parameter "
            r"of planner_camera; allowed: .*view_range, memory",
        ),
        (
            "planner",
            {"view_range": 2.0},
            r"'imitation.teacher_params.view_range' is not a parameter of planner;",
        ),
    ],
)
def test_camera_planner_parameters_out_of_range_are_refused(name: str, params: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        check_teacher(name, {}, "run.yaml", params)


def test_a_teacher_name_that_is_no_agent_is_refused_naming_it() -> None:
    with pytest.raises(
        ValueError,
        match=r"^run.yaml: key 'imitation.teacher' must be one of .*planner_camera.*, got 'planner_cam'$",
    ):
        check_teacher("planner_cam", {}, "run.yaml")


def test_a_planner_teacher_of_a_rule_is_refused_naming_it() -> None:
    with pytest.raises(
        ValueError,
        match=rf"^a planner teacher must be one of {', '.join(PLANNERS)}, got 'bee_ttc'$",
    ):
        PlannerTeacher(name="bee_ttc")


def test_a_rule_teacher_missing_its_env_setting_is_refused_naming_it() -> None:
    with pytest.raises(ValueError, match=r"run.yaml: the teacher 'vfh' reads what the env setting .* gives"):
        check_teacher("vfh", {}, "run.yaml")


def test_the_camera_planner_reads_its_keys_while_the_student_never_sees_them(tmp_path: Path) -> None:
    config, _ = tiny_train_config(tmp_path, total=64, imitation={"teacher": "planner_camera"})
    teacher = _RecordingCameraTeacher()
    envs, eval_env = build_envs(config, in_process=True, teacher_settings=privileged_settings(teacher))
    try:
        model = new_model(config, envs)
        assert not set(model.observation_space.spaces) & set(PRIVILEGED_KEYS)
        flights = fly(envs, teacher, steps=10, gamma=0.99, student=model)
        assert {"camera", "depth_bin_edges"} <= teacher.seen and set(CAMERA_PLANNER_KEYS) <= teacher.seen
        assert not set(flights.observations) & set(PRIVILEGED_KEYS) and len(flights) == 10
        assert float(abs(flights.teacher_actions).max()) > 0.0  # it acted, not a stub's zeros
    finally:
        close_quietly(envs)
        close_quietly(eval_env)


def test_a_dagger_run_taught_by_the_camera_planner_records_its_teacher(tmp_path: Path) -> None:
    imitation = {"teacher": "planner_camera", "rounds": 2, "steps_per_round": 8, "epochs": 1}
    config, record = teacher_started_record(tmp_path, imitation)
    files = RunFiles.of(tmp_path / "runs", config.name)
    summary = json.loads(record.read_text())["sessions"][-1]["imitation"]
    assert summary["teacher"] == "planner_camera" and summary["teacher_env"] == {"observe_layout": True}
    assert [r["states"] for r in summary["rounds"]] == [8, 16]
    assert files.policy.is_file()
