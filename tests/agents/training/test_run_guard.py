"""The run guard: how a training session that ends early is recorded, checkpointed and cleaned up, and that
the model gets every hyperparameter of the config's ppo block."""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

import pytest
from helpers import tiny_train_config
from stable_baselines3.common.callbacks import CallbackList

from agents.training.envs import build_envs, close_quietly
from agents.training.outputs import RunFiles
from agents.training.ppo import hyperparameters, new_model
from agents.training.run_guard import run_guard
from agents.training.run_record import FAILED, FINISHED, INTERRUPTED, RUNNING, SessionRecord


@dataclass
class Workers:
    """Stands in for a vector env: whether it was closed."""

    closed: bool = False

    def close(self) -> None:
        self.closed = True


@dataclass
class Model:
    """Stands in for a model: its step count."""

    num_timesteps: int = 0


@dataclass
class Checkpoints:
    """Stands in for saving a checkpoint: the step counts saved."""

    model: Model
    saved: list[int] = field(default_factory=list)

    def __call__(self) -> None:
        self.saved.append(self.model.num_timesteps)


def _session(files: RunFiles) -> dict:
    return json.loads(files.record.read_text())["sessions"][-1]


def _started(tmp_path: Path):
    files = RunFiles.of(tmp_path, "run")
    files.run_dir.mkdir(parents=True)
    model = Model()
    record = SessionRecord(files, {}, command="flownav train", keep_earlier=False, steps_at_start=0)
    return files, model, record, Checkpoints(model)


def test_an_interrupt_while_learning_checkpoints_and_lets_the_outputs_be_written(tmp_path: Path) -> None:
    files, model, record, checkpoints = _started(tmp_path)
    workers = Workers()

    def learn() -> None:
        model.num_timesteps = 96
        raise KeyboardInterrupt

    with run_guard(files, workers) as guard:  # type: ignore[arg-type]
        guard.start(model, record, checkpoints)  # type: ignore[arg-type]
        guard.learn(learn, CallbackList([]))
        assert not workers.closed  # the block goes on: the outputs are written inside it
        guard.end(selected="last: 96 steps")
    assert workers.closed and checkpoints.saved == [96] and guard.status == INTERRUPTED
    session = _session(files)
    assert (session["status"], session["interrupted"], session["steps_this_session"]) == (
        INTERRUPTED,
        True,
        96,
    )


def test_a_finished_session_checkpoints_once_and_records_its_end(tmp_path: Path) -> None:
    files, model, record, checkpoints = _started(tmp_path)
    with run_guard(files) as guard:
        guard.start(model, record, checkpoints)  # type: ignore[arg-type]
        guard.learn(lambda: setattr(model, "num_timesteps", 64), CallbackList([]))
        guard.end(selected="last: 64 steps")
    assert checkpoints.saved == [64] and _session(files)["status"] == FINISHED
    assert json.loads(files.record.read_text())["selected"] == "last: 64 steps"


def test_a_full_disk_while_learning_is_recorded_first_and_named_after_the_run(tmp_path: Path) -> None:
    files, model, record, checkpoints = _started(tmp_path)
    workers = Workers()

    def full_disk() -> None:
        raise OSError(28, "No space left on device")

    with pytest.raises(OSError, match=r"No space left on device.*" + str(files.run_dir)):
        with run_guard(files, workers) as guard:  # type: ignore[arg-type]
            guard.start(model, record, checkpoints)  # type: ignore[arg-type]
            guard.learn(full_disk, CallbackList([]))
    session = _session(files)
    assert session["status"] == FAILED and session["error"] == "OSError: [Errno 28] No space left on device"
    assert checkpoints.saved == [0] and workers.closed


def test_a_failure_writing_the_outputs_is_recorded_with_its_error(tmp_path: Path) -> None:
    files, model, record, checkpoints = _started(tmp_path)
    with pytest.raises(ValueError, match="no policy"):
        with run_guard(files) as guard:
            guard.start(model, record, checkpoints)  # type: ignore[arg-type]
            guard.learn(lambda: None, CallbackList([]))
            raise ValueError("no policy")
    session = _session(files)
    assert (session["status"], session["error"]) == (FAILED, "ValueError: no policy")


def test_an_interrupted_teacher_start_ends_the_session_at_step_0_and_goes_on(tmp_path: Path) -> None:
    files, model, record, checkpoints = _started(tmp_path)
    workers = Workers()

    def imitate() -> dict:
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        with run_guard(files, workers) as guard:  # type: ignore[arg-type]
            guard.start(model, record, checkpoints)  # type: ignore[arg-type]
            guard.teacher_start(imitate)
    session = _session(files)
    assert (session["status"], session["steps_this_session"]) == (INTERRUPTED, 0)
    assert checkpoints.saved == [] and workers.closed


def test_a_teacher_start_writes_its_summary_into_the_record(tmp_path: Path) -> None:
    files, model, record, checkpoints = _started(tmp_path)
    with run_guard(files) as guard:
        guard.start(model, record, checkpoints)  # type: ignore[arg-type]
        guard.teacher_start(lambda: {"rounds": 1})
    session = _session(files)
    assert session["imitation"] == {"rounds": 1} and session["status"] == RUNNING


def test_a_failure_before_the_record_closes_the_workers_and_writes_nothing(tmp_path: Path) -> None:
    files, workers = RunFiles.of(tmp_path, "run"), Workers()
    with pytest.raises(ValueError, match="already holds a run"):
        with run_guard(files, workers):  # type: ignore[arg-type]
            raise ValueError("already holds a run")
    assert workers.closed and not files.record.exists()


def test_learning_before_the_session_is_started_is_refused(tmp_path: Path) -> None:
    with run_guard(RunFiles.of(tmp_path, "run")) as guard:
        with pytest.raises(
            RuntimeError, match=r"the session's record is not started: call RunGuard.start first"
        ):
            guard.learn(lambda: None, CallbackList([]))
        with pytest.raises(
            RuntimeError, match=r"the session's record is not started: call RunGuard.start first"
        ):
            guard.teacher_start(dict)


def test_the_model_gets_every_hyperparameter_of_the_ppo_block(tmp_path: Path) -> None:
    ppo = {
        "learning_rate": 0.001,
        "n_steps": 48,
        "batch_size": 24,
        "n_epochs": 3,
        "gamma": 0.97,
        "gae_lambda": 0.9,
        "clip_range": 0.15,
        "ent_coef": 0.01,
        "net_arch": [12, 8],
        "log_std_init": -0.5,
        "lstm_hidden_size": 0,
    }
    config, _ = tiny_train_config(tmp_path, total=48, ppo=ppo)
    assert asdict(config.ppo).keys() == ppo.keys()  # a new field must be added here and to new_model
    envs, eval_env = build_envs(config, in_process=True)
    try:
        model = new_model(config, envs)
    finally:
        close_quietly(envs)
        close_quietly(eval_env)
    for name in ("learning_rate", "n_steps", "batch_size", "n_epochs", "gamma", "gae_lambda", "ent_coef"):
        assert getattr(model, name) == ppo[name], name
    assert model.clip_range(1.0) == ppo["clip_range"]
    assert model.policy.net_arch == {"pi": [12, 8], "vf": [12, 8]} or model.policy.net_arch == [12, 8]
    assert math.isclose(float(model.policy.log_std.detach()[0]), -0.5)
    assert hyperparameters(config.ppo).startswith(
        "learning_rate=0.001, n_steps=48, batch_size=24, n_epochs=3"
    )
