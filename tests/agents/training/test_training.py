"""PPO training from a config: outputs only under runs/<name>/, resume with its history, Ctrl-C, atomic
checkpoints, deliberate shipping, and sensor randomisation."""

from __future__ import annotations

import json
import multiprocessing
import os
import shutil
import signal
import threading
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml
from helpers import SMALL, tiny_train_config

import flownav_env  # noqa: F401
from agents.common.manifest import MANIFEST_NAME, file_sha256, read_manifest
from agents.common.saved_models import latest_checkpoint, read_saved_model
from agents.common.seeds import TEST_SEED_START
from agents.common.yaml_config import ConfigError, load_config
from agents.policies import UnverifiedPolicyWarning, load_agent
from agents.training import callbacks
from agents.training.envs import IgnoringInterrupts, close_quietly
from agents.training.outputs import RunFiles
from agents.training.ppo import train
from agents.training.train_config import TrainConfig
from agents.training.wrappers import SensorRandomization
from flownav_env.settings_check import check_env_kwargs


@dataclass
class ResumedRun:
    files: RunFiles
    config_path: Path
    runs_dir: Path
    shipped: Path


@pytest.fixture(scope="module")
def resumed_run(tmp_path_factory: pytest.TempPathFactory) -> ResumedRun:
    """128 steps, a truncated newer checkpoint as a crash mid-save leaves, then resumed to 256 and shipped."""
    tmp_path = tmp_path_factory.mktemp("run")
    config, config_path = tiny_train_config(tmp_path, total=128)
    runs_dir, shipped = tmp_path / "runs", tmp_path / "shipped"
    train(config, config_path=config_path, resume=False, runs_dir=runs_dir)
    files = RunFiles.of(runs_dir, "tiny_ppo")
    newest = files.checkpoints / "tiny_ppo_128_steps.zip"
    cut = newest.read_bytes()
    (files.checkpoints / "tiny_ppo_192_steps.zip").write_bytes(cut[: len(cut) // 2])
    config.total_timesteps = 256  # as if the first run had been interrupted at 128 of 256 steps
    train(config, config_path=config_path, resume=True, runs_dir=runs_dir, ship_to=shipped)
    return ResumedRun(files, config_path, runs_dir, shipped)


def test_a_run_writes_everything_under_runs_and_nothing_elsewhere(resumed_run: ResumedRun) -> None:
    files = resumed_run.files
    for path in (files.policy, files.config, files.record, files.evaluations, files.curve, files.best_model):
        assert path.is_file(), path
    assert (files.tensorboard).is_dir()
    assert sorted(p.name for p in files.run_dir.parent.parent.iterdir()) == [
        "runs",
        "shipped",
        "tiny_ppo_config.yaml",
    ]
    with pytest.warns(UnverifiedPolicyWarning, match="not a shipped policy"):  # runs/ has no manifest
        agent = load_agent("ppo_flow", files.policy)
    env = gym.make("FlowNavSingle-v0", **SMALL)
    observation, _ = env.reset(seed=TEST_SEED_START)
    action, _ = agent.predict(observation, deterministic=True)
    env.close()
    assert action.shape == (3,)


def test_resume_keeps_every_evaluation_and_ships_the_best_of_all_sessions(resumed_run: ResumedRun) -> None:
    files = resumed_run.files
    with np.load(files.evaluations) as evaluations:
        timesteps, means = evaluations["timesteps"], evaluations["results"].mean(axis=1)
    assert timesteps.tolist() == [64, 128, 192, 256]  # both sessions, in order
    best = int(np.argmax(means))
    assert read_saved_model(files.policy).num_timesteps == timesteps[best]
    record = json.loads(files.record.read_text())
    assert (
        record["selected"] == f"best held-out eval: mean return {means[best]:.2f} at {timesteps[best]} steps"
    )
    assert record["total_timesteps"] == 256 and len(record["sessions"]) == 2
    # The truncated 192-step checkpoint was skipped: the second session resumed at 128.
    assert [s["steps_this_session"] for s in record["sessions"]] == [128, 128]
    assert record["sessions"][-1]["env_estimator_defaults"] == {"fast_threshold": 10}
    assert record["sessions"][-1]["code"].startswith("commit") and record["sessions"][-1]["gl_renderer"]


def test_shipping_copies_the_run_together_and_records_its_hash(resumed_run: ResumedRun, capsys) -> None:
    from agents.cli import main

    files = resumed_run.files
    for shipped in (resumed_run.shipped, resumed_run.shipped.parent / "shipped_again"):
        if not shipped.exists():  # --ship shipped the first at the end of training; ship a second by hand
            args = ["train", "--config", str(resumed_run.config_path), "--ship-only"]
            assert main([*args, "--runs-dir", str(resumed_run.runs_dir), "--ship-to", str(shipped)]) == 0
        for source, name in files.shipped_names().items():
            assert (shipped / name).read_bytes() == source.read_bytes(), name
        assert read_manifest(shipped / MANIFEST_NAME) == {"tiny_ppo.zip": file_sha256(files.policy)}
        assert sorted(p.name for p in shipped.iterdir() if p.name.startswith(".")) == []  # no temporaries
    assert (
        main(["train", "--config", str(resumed_run.config_path), "--ship-only", "--runs-dir", "/none"]) == 2
    )
    assert "has no tiny_ppo.zip: train it first" in capsys.readouterr().err


def test_resumed_evaluation_drops_lost_steps_and_knows_an_older_runs_best(
    resumed_run: ResumedRun, tmp_path: Path
) -> None:
    from stable_baselines3.common.vec_env import DummyVecEnv

    shutil.copytree(resumed_run.files.run_dir, tmp_path / "tiny_ppo")
    files = RunFiles.of(tmp_path, "tiny_ppo")
    files.best_info.unlink()  # as a run from before best_model.json
    with np.load(files.evaluations) as evaluations:
        timesteps, means = evaluations["timesteps"], evaluations["results"].mean(axis=1)
    best = int(np.argmax(means))
    eval_env = DummyVecEnv([lambda: gym.make("CartPole-v1")])
    callback = callbacks.ResumableEvalCallback(eval_env, files, resume_step=128, n_eval_episodes=1)
    eval_env.close()
    assert callback.evaluations_timesteps == [64, 128]  # 192 and 256 were trained after the resume point
    assert callback.best_mean_reward == pytest.approx(means[best])
    assert json.loads(files.best_info.read_text()) == {
        "mean_return": means[best],
        "timesteps": timesteps[best],
    }


@pytest.mark.parametrize(
    "damaged",
    [
        b"",
        b"{",
        b"[]",
        b'{"timesteps": 64}',
        b'{"mean_return": "high"}',
        b'{"mean_return": NaN}',
        b"\xff\xfe",
    ],
)
def test_a_damaged_best_model_record_is_moved_aside_and_rebuilt_from_the_evaluations(
    resumed_run: ResumedRun, tmp_path: Path, capsys, damaged: bytes
) -> None:
    from stable_baselines3.common.vec_env import DummyVecEnv

    shutil.copytree(resumed_run.files.run_dir, tmp_path / "tiny_ppo")
    files = RunFiles.of(tmp_path, "tiny_ppo")
    files.best_info.write_bytes(damaged)
    with np.load(files.evaluations) as evaluations:
        means = evaluations["results"].mean(axis=1)
    capsys.readouterr()
    eval_env = DummyVecEnv([lambda: gym.make("CartPole-v1")])
    callback = callbacks.ResumableEvalCallback(eval_env, files, resume_step=128, n_eval_episodes=1)
    eval_env.close()
    assert callback.best_mean_reward == pytest.approx(means[int(np.argmax(means))])
    assert capsys.readouterr().out.splitlines()[-1] == (
        f"warning: {files.best_info} unreadable; kept as best_model.unreadable.json, the best model's return is "
        "taken from the evaluations"
    )
    assert (files.best_info.parent / "best_model.unreadable.json").read_bytes() == damaged
    assert json.loads(files.best_info.read_text())["mean_return"] == pytest.approx(callback.best_mean_reward)


def test_a_fresh_run_refuses_a_folder_holding_an_earlier_run(resumed_run: ResumedRun) -> None:
    config, _ = tiny_train_config(resumed_run.config_path.parent, total=128)
    with pytest.raises(ValueError, match=r"tiny_ppo already holds a run .*continue it with --resume"):
        train(config, config_path=resumed_run.config_path, resume=False, runs_dir=resumed_run.runs_dir)


def test_latest_checkpoint_skips_a_truncated_newest(resumed_run: ResumedRun, tmp_path: Path, capsys) -> None:
    good = tmp_path / "tiny_ppo_128_steps.zip"
    shutil.copyfile(resumed_run.files.checkpoints / "tiny_ppo_128_steps.zip", good)
    (tmp_path / "tiny_ppo_1024_steps.zip").write_bytes(good.read_bytes()[:1000])
    (tmp_path / "tiny_ppo_2048_steps.tmp.zip").write_bytes(b"an unfinished save")
    assert latest_checkpoint(tmp_path) == good
    assert "warning: skipping checkpoint" in capsys.readouterr().out
    assert latest_checkpoint(tmp_path / "none") is None


def test_ctrl_c_with_subprocess_workers_still_writes_the_run(tmp_path: Path, monkeypatch) -> None:
    def ctrl_c_at_step_40(self) -> bool:
        if self.n_calls == 40:  # after the first evaluation (step 64 of 2 envs)
            for worker in multiprocessing.active_children():  # Ctrl-C reaches the whole process group
                os.kill(worker.pid, signal.SIGINT)
            time.sleep(0.5)
            raise KeyboardInterrupt
        return True

    monkeypatch.setattr(callbacks.WallClockBudget, "_on_step", ctrl_c_at_step_40)
    config, config_path = tiny_train_config(tmp_path, total=512, name="tiny_two", n_envs=2)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        train(
            config, config_path=config_path, resume=False, runs_dir=tmp_path / "runs", ship_to=tmp_path / "s"
        )
    assert not [w for w in caught if "not of the same type" in str(w.message)]
    files = RunFiles.of(tmp_path / "runs", "tiny_two")
    for path in (files.policy, files.config, files.record, files.evaluations, files.curve):
        assert path.is_file(), path
    assert (files.checkpoints / "tiny_two_80_steps.zip").is_file()
    assert json.loads(files.record.read_text())["sessions"][0]["interrupted"] is True
    assert not (tmp_path / "s").exists()  # an interrupted run is not shipped
    # Its progress bar is closed: a live one's refresh thread would print into whatever runs next.
    assert not [thread for thread in threading.enumerate() if type(thread).__name__ == "_RefreshThread"]


def test_workers_ignore_ctrl_c_and_a_dead_worker_closes_quietly() -> None:
    from stable_baselines3.common.vec_env import SubprocVecEnv

    envs = SubprocVecEnv(
        [IgnoringInterrupts(lambda: gym.make("CartPole-v1")) for _ in range(2)], start_method="forkserver"
    )
    envs.reset()
    first, second = envs.processes
    os.kill(first.pid, signal.SIGINT)
    time.sleep(0.3)
    envs.step(np.zeros(2, dtype=np.int64))
    assert first.is_alive()
    os.kill(second.pid, signal.SIGKILL)
    second.join(timeout=5)
    close_quietly(envs)  # SB3's close would raise on the dead worker's pipe
    assert not first.is_alive() and envs.closed


def test_workers_interrupted_mid_step_still_close() -> None:
    """A stop signal inside SB3's step_wait leaves some replies read and ``waiting`` set; SB3's own close
    then waits forever for the replies already read (a training run hung there after its checkpoint)."""
    import threading

    from stable_baselines3.common.vec_env import SubprocVecEnv

    envs = SubprocVecEnv(
        [IgnoringInterrupts(lambda: gym.make("CartPole-v1")) for _ in range(2)], start_method="forkserver"
    )
    envs.reset()
    envs.step_async(np.zeros(2, dtype=np.int64))
    envs.remotes[0].recv()  # where the interrupt struck: the first worker's reply read, the second's not
    closing = threading.Thread(target=close_quietly, args=(envs,), daemon=True)
    closing.start()
    closing.join(timeout=30)
    assert not closing.is_alive(), "close_quietly hung on replies that had already been read"
    assert envs.closed and not any(process.is_alive() for process in envs.processes)


def test_zero_timesteps_are_rejected_from_the_config_and_the_command_line(tmp_path: Path, capsys) -> None:
    from agents.cli import main

    config, config_path = tiny_train_config(tmp_path, total=128)
    args = ["train", "--config", str(config_path), "--runs-dir", str(tmp_path / "runs")]
    assert main([*args, "--total-timesteps", "0"]) == 2
    error = capsys.readouterr().err
    assert "--total-timesteps must be in [1, 100000000] (the config's total_timesteps range), got 0" in error
    assert main([*args, "--max-minutes", "0"]) == 2
    assert "--max-minutes must be in [0.1, 10000.0]" in capsys.readouterr().err
    config.total_timesteps = 0
    with pytest.raises(ConfigError, match=r"key 'total_timesteps' must be in \[1, 100000000\], got 0"):
        train(config, config_path=config_path, resume=False, runs_dir=tmp_path / "runs")
    assert not (tmp_path / "runs").exists()


def test_sensor_randomization_draws_within_ranges_reproducibly() -> None:
    def draws(seed: int) -> dict:
        env = SensorRandomization(
            gym.make("FlowNav-v0", **SMALL), {"rotation_error": [0.0, 0.1], "brightness": [0.5, 1.5]}
        )
        _, info = env.reset(seed=seed)
        env.close()
        return info

    first, again, other = draws(3), draws(3), draws(4)
    assert 0.0 <= first["sensor_rotation_error"] <= 0.1 and 0.5 <= first["sensor_brightness"] <= 1.5
    assert first["sensor_rotation_error"] == again["sensor_rotation_error"]
    assert first["sensor_rotation_error"] != other["sensor_rotation_error"]
    with pytest.raises(ValueError, match=r"ranges may only name .*got \['speed'\]"):
        SensorRandomization(gym.make("FlowNav-v0", **SMALL), {"speed": [0, 1]})


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ({"name": "x", "total_steps": 5}, r"unknown key 'total_steps'"),
        ({"name": "x", "n_envs": "two"}, r"key 'n_envs' must be an integer, got 'two'"),
        ({"name": "x", "n_envs": 0}, r"key 'n_envs' must be in \[1, 64\], got 0"),
        ({"name": "x", "total_timesteps": 0}, r"key 'total_timesteps' must be in \[1, 100000000\], got 0"),
        ({"name": "x", "ppo": {"gamma": 1.5}}, r"key 'ppo.gamma' must be in \[0.0, 1.0\], got 1.5"),
        ({"name": "x", "ppo": {"lr": 0.1}}, r"unknown key 'ppo.lr'"),
        (
            {"name": "x", "randomize": {"brightness": [2.0, 1.0]}},
            r"randomize.brightness' must be \[low, high\]",
        ),
        ({"name": "x", "env": {"forward_speed": -1}}, r"key 'env.forward_speed': forward_speed must be in"),
        ({"name": "x", "env": {"wind": 3}}, r"unknown key 'env.wind' \(not a FlowNavEnv argument\)"),
        ({"n_envs": 2}, r"missing required key 'name'"),
    ],
)
def test_train_config_errors_name_the_file_and_the_key(tmp_path: Path, content: dict, message: str) -> None:

    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(content))
    with pytest.raises(ValueError, match=message) as error:
        config = load_config(path, TrainConfig)
        check_env_kwargs(config.env, str(path))
    assert str(path) in str(error.value)
