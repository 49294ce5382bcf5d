"""``flownav train`` when things go wrong: output folders that take no files, a full disk or a file-size limit
mid-run, a damaged evaluation history, Ctrl-C, SIGTERM and ``kill -9``, and a budget below one rollout."""

from __future__ import annotations

import errno
import json
import multiprocessing
import re
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from helpers import tiny_train_config

from agents.cli import build_parser, main
from agents.common.folders import check_writable_folder, naming_file
from agents.training import callbacks, ppo
from agents.training.outputs import RunFiles
from agents.training.run_record import FAILED, INTERRUPTED, KILLED
from agents.training.train_config import rollout_note

TRAIN = [sys.executable, "-c", "from agents.cli import main; raise SystemExit(main())", "train"]


def test_checking_a_writable_folder_leaves_nothing_behind(tmp_path: Path) -> None:
    check_writable_folder(tmp_path / "new" / "runs")
    assert list(tmp_path.iterdir()) == []
    (tmp_path / "old").mkdir()
    check_writable_folder(tmp_path / "old")
    assert list(tmp_path.iterdir()) == [tmp_path / "old"] and list((tmp_path / "old").iterdir()) == []


def test_a_folder_that_takes_no_files_is_refused_in_one_line(tmp_path: Path, monkeypatch) -> None:
    (tmp_path / "a_file").write_text("")
    with pytest.raises(
        ValueError, match=r"^output folder .*a_file is a file, not a folder: pick another --x$"
    ):
        check_writable_folder(tmp_path / "a_file", "--x")
    with pytest.raises(
        ValueError, match=r"^cannot write to the output folder .*a_file/sub \(Not a directory\)$"
    ):
        check_writable_folder(tmp_path / "a_file" / "sub")

    def read_only(self, *args, **kwargs):  # root writes into a chmod 555 folder: refuse as a read-only mount
        raise OSError(errno.EROFS, "Read-only file system", str(self))

    monkeypatch.setattr(Path, "open", read_only)
    with pytest.raises(
        ValueError, match=r"output folder .*ro \(Read-only file system\): pick another --runs-dir"
    ):
        check_writable_folder(tmp_path / "ro", "--runs-dir")
    assert list(tmp_path.iterdir()) == [tmp_path / "a_file"]  # no probe, no folder left


def test_a_write_error_without_a_file_name_is_raised_naming_the_file_without_a_chain(tmp_path: Path) -> None:
    with pytest.raises(OSError) as caught, naming_file(tmp_path / "out.zip"):
        raise OSError(errno.ENOSPC, "No space left on device")
    assert caught.value.errno == errno.ENOSPC and caught.value.filename == str(tmp_path / "out.zip")
    assert caught.value.__suppress_context__ and caught.value.__cause__ is None


@pytest.mark.parametrize(
    ("options", "refused"),
    [
        (["--runs-dir", "{blocked}"], "--runs-dir"),
        (["--ship", "--ship-to", "{blocked}"], "--ship-to"),
        (["--seeds", "0-1", "--ship", "--ship-to", "{blocked}"], "--ship-to"),
        (["--seeds", "0", "--park", "--parked-dir", "{blocked}"], "--parked-dir"),
    ],
)
def test_train_checks_its_output_folders_before_building_any_env(
    tmp_path: Path, monkeypatch, capsys, options: list[str], refused: str
) -> None:
    def no_envs(*args, **kwargs):
        raise AssertionError("envs were built before the output folders were checked")

    monkeypatch.setattr(ppo, "build_envs", no_envs)
    _, config_path = tiny_train_config(tmp_path, total=64)
    (tmp_path / "a_file").write_text("")
    blocked = str(tmp_path / "a_file" / "out")
    args = ["train", "--config", str(config_path), "--runs-dir", str(tmp_path / "runs")]
    assert main([*args, *(o.format(blocked=blocked) for o in options)]) == 2
    error = capsys.readouterr().err.strip()
    assert re.fullmatch(
        rf"flownav train: error: cannot write to the output folder {re.escape(blocked)}\S* \(Not a directory\): "
        rf"pick another {refused}",
        error,
    ), error


def test_a_full_disk_mid_run_ends_in_one_line_keeps_the_checkpoints_and_closes_the_workers(
    tmp_path: Path, monkeypatch, capsys
) -> None:
    from stable_baselines3.common.base_class import BaseAlgorithm

    original_save = BaseAlgorithm.save

    def save_until_the_disk_is_full(self, path, *args, **kwargs):
        if "_128_steps" in str(path):  # as a full disk: OSError without a file name, partway into the file
            Path(path).write_bytes(b"partial")
            raise OSError(errno.ENOSPC, "No space left on device")
        return original_save(self, path, *args, **kwargs)

    monkeypatch.setattr(BaseAlgorithm, "save", save_until_the_disk_is_full)
    _, config_path = tiny_train_config(tmp_path, total=512, name="full", n_envs=2)
    runs_dir = tmp_path / "runs"
    code = main(["train", "--config", str(config_path), "--runs-dir", str(runs_dir)])
    files = RunFiles.of(runs_dir, "full")
    error = capsys.readouterr().err.strip()
    assert code == 1
    assert (
        error == f"flownav train: error: No space left on device: {files.checkpoints / 'full_128_steps.zip'}"
    )
    assert [p.name for p in files.checkpoints.iterdir()] == ["full_64_steps.zip"]  # kept; no partial file
    assert not multiprocessing.active_children()  # the env workers were closed
    session = json.loads(files.record.read_text())["sessions"][-1]
    assert session["status"] == FAILED and session["error"].startswith("OSError: [Errno 28]")
    assert session["steps_this_session"] == 128 and session["ended"] is not None


@pytest.mark.slow
def test_a_file_size_limit_ends_a_real_run_in_one_line_without_hanging(tmp_path: Path) -> None:
    _, config_path = tiny_train_config(tmp_path, total=512, name="limited", n_envs=2)
    runs_dir = tmp_path / "runs"

    def limit_file_size() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # so that a write past the limit raises EFBIG
        resource.setrlimit(resource.RLIMIT_FSIZE, (8_000, resource.RLIM_INFINITY))

    result = subprocess.run(
        [*TRAIN, "--config", str(config_path), "--runs-dir", str(runs_dir)],
        preexec_fn=limit_file_size,
        capture_output=True,
        text=True,
        timeout=180,
    )
    checkpoint = RunFiles.of(runs_dir, "limited").checkpoints / "limited_64_steps.zip"
    assert result.returncode == 1, result.stderr
    assert result.stderr.strip() == f"flownav train: error: File too large: {checkpoint}"
    assert not checkpoint.parent.is_dir() or not any(checkpoint.parent.iterdir())


def _eval_callback(files: RunFiles) -> callbacks.ResumableEvalCallback:
    from stable_baselines3.common.vec_env import DummyVecEnv

    eval_env = DummyVecEnv([lambda: gym.make("CartPole-v1")])
    try:
        return callbacks.ResumableEvalCallback(eval_env, files, resume_step=128, n_eval_episodes=1)
    finally:
        eval_env.close()


def _write_evaluations(path: Path, kind: str) -> None:
    good = {"timesteps": np.array([64, 128]), "results": np.zeros((2, 1)), "ep_lengths": np.ones((2, 1), int)}
    if kind == "empty":
        path.write_bytes(b"")
    elif kind == "random bytes":
        path.write_bytes(np.random.default_rng(0).bytes(2000))
    elif kind in ("truncated", "cut in its header"):
        np.savez(path, **good)
        data = path.read_bytes()
        path.write_bytes(data[: len(data) // 2] if kind == "truncated" else data[:40])
    elif kind == "other arrays":
        np.savez(path, steps=good["timesteps"])
    elif kind == "shapes that do not match":
        np.savez(path, **{**good, "results": np.zeros((3, 1))})
    elif kind == "one-dimensional results":
        np.savez(path, **{**good, "results": np.zeros(2)})
    elif kind == "pickled objects":
        np.savez(path, **{**good, "results": np.array([None, {}], dtype=object)})
    elif kind == "a single array":
        np.save(path.with_suffix(".npy"), good["timesteps"])
        path.with_suffix(".npy").rename(path)


@pytest.mark.parametrize(
    "kind",
    [
        "empty",
        "random bytes",
        "truncated",
        "cut in its header",
        "other arrays",
        "shapes that do not match",
        "one-dimensional results",
        "pickled objects",
        "a single array",
    ],
)
def test_an_unreadable_evaluation_history_starts_a_new_one_with_a_warning(
    tmp_path: Path, capsys, kind: str
) -> None:
    files = RunFiles.of(tmp_path, "tiny_ppo")
    files.run_dir.mkdir()
    _write_evaluations(files.evaluations, kind)
    damaged = files.evaluations.read_bytes()
    callback = _eval_callback(files)
    assert callback.evaluations_timesteps == [] and callback.evaluations_results == []
    output = capsys.readouterr().out.strip()
    assert re.fullmatch(
        rf"warning: earlier evaluations {re.escape(str(files.evaluations))} unreadable \(.+\); kept as "
        r"evaluations.unreadable.npz, starting a new history",
        output,
        flags=re.DOTALL,
    ), output
    # Moved aside: the new history, its curve and shipping never read the damaged file.
    assert not files.evaluations.exists()
    assert (files.run_dir / "evaluations.unreadable.npz").read_bytes() == damaged


def test_a_budget_below_one_rollout_is_said_and_rounded_up_to_whole_rollouts(tmp_path: Path, capsys) -> None:
    config, _ = tiny_train_config(tmp_path, total=256, n_envs=2, ppo={"n_steps": 1024})
    assert rollout_note(config, 0) == (
        "total_timesteps 256 is less than one rollout of 2,048 steps (n_steps 1024 × n_envs 2): training 2,048"
    )
    config.total_timesteps = 3000
    assert rollout_note(config, 0).endswith("is not a whole number of rollouts of 2,048 steps "
                                            "(n_steps 1024 × n_envs 2): training 4,096")  # fmt: skip
    assert rollout_note(config, 1024) == (
        "total_timesteps 3,000 is less than one rollout of 2,048 steps (n_steps 1024 × n_envs 2) after the "
        "resumed 1,024: training to 3,072"
    )
    config.total_timesteps = 4096
    assert rollout_note(config, 0) is None and rollout_note(config, 4096) is None

    _, config_path = tiny_train_config(tmp_path, total=128)
    runs_dir = tmp_path / "runs"
    args = ["train", "--config", str(config_path), "--runs-dir", str(runs_dir), "--total-timesteps", "32"]
    assert main([*args, "--max-minutes", "5"]) == 0
    assert "total_timesteps 32 is less than one rollout of 64 steps (n_steps 64 × n_envs 1): training 64" in (
        capsys.readouterr().out
    )
    record = json.loads(RunFiles.of(runs_dir, "tiny_ppo").record.read_text())
    assert record["total_timesteps"] == 64
    # Called from code, the command is rebuilt from the parsed options: every one that was given is there.
    assert record["command"] == (
        f"flownav train --config {config_path} --runs-dir {runs_dir} --total-timesteps 32 --max-minutes 5.0"
    )
    assert record["sessions"][0]["command"] == record["command"]


def _wait_for_checkpoint(files: RunFiles, process: subprocess.Popen, timeout: float = 120) -> None:
    deadline = time.monotonic() + timeout
    while not (files.checkpoints.is_dir() and any(files.checkpoints.glob("*_steps.zip"))):
        assert process.poll() is None and time.monotonic() < deadline, "no checkpoint came"
        time.sleep(0.2)


def test_a_killed_session_stays_in_the_record_and_an_interrupted_one_exits_130(tmp_path: Path) -> None:
    _, config_path = tiny_train_config(tmp_path, total=100_000)
    runs_dir = tmp_path / "runs"
    files = RunFiles.of(runs_dir, "tiny_ppo")
    command = [*TRAIN, "--config", str(config_path), "--runs-dir", str(runs_dir), "--max-minutes", "5"]

    killed = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _wait_for_checkpoint(files, killed)
    killed.kill()
    killed.wait(timeout=30)
    first = json.loads(files.record.read_text())["sessions"][0]
    assert first["ended"] is None and first["status"] == "running"
    assert first["command"] == f"flownav train --config {config_path} --runs-dir {runs_dir} --max-minutes 5"

    resumed = subprocess.Popen(
        [*command, "--resume"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True
    )
    steps_before = len(list(files.checkpoints.glob("*_steps.zip")))
    deadline = time.monotonic() + 120
    while len(list(files.checkpoints.glob("*_steps.zip"))) <= steps_before and time.monotonic() < deadline:
        time.sleep(0.2)
    resumed.send_signal(signal.SIGINT)
    _, error = resumed.communicate(timeout=120)
    assert resumed.returncode == 130, error
    last = error.strip().splitlines()[-1]
    assert re.fullmatch(
        rf"flownav train: interrupted: {re.escape(str(files.run_dir))} saved at [\d,]+ steps; resume with: "
        rf"flownav train --config {re.escape(str(config_path))} --runs-dir {re.escape(str(runs_dir))} "
        r"--max-minutes 5 --resume",
        last,
    ), last
    sessions = json.loads(files.record.read_text())["sessions"]
    assert [s["status"] for s in sessions] == [KILLED, INTERRUPTED]
    assert sessions[1]["ended"] is not None and sessions[1]["command"].endswith("--max-minutes 5 --resume")


def test_train_help_quotes_no_measured_speed_up(capsys) -> None:
    with pytest.raises(SystemExit):
        build_parser().parse_args(["train", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "same rollouts; on a small machine more steps per second than one at a time" in text
    assert not re.search(r"\d\s*[x×]\b", text), text
