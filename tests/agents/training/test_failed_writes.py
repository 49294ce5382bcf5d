"""A write that fails mid-run (full disk, file-size limit) changes nothing a resume cannot restore: the
evaluation history keeps every evaluation, the best model agrees with it, and the run chooses the policy an
uninterrupted run chooses."""

from __future__ import annotations

import errno
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
from helpers import tiny_train_config

from agents.cli import main
from agents.common.folders import replacing_atomically
from agents.common.saved_models import read_saved_model
from agents.training import callbacks
from agents.training.outputs import RunFiles
from agents.training.run_record import FAILED, FINISHED

# One evaluation, at the last step, after a checkpoint of the same step: the failed write is the run's last.
CONFIG = {"total": 64, "checkpoint_every": 32, "eval_every": 64}


def _train(config_path: Path, runs_dir: Path, *more: str) -> int:
    return main(["train", "--config", str(config_path), "--runs-dir", str(runs_dir), *more])


def _outcome(files: RunFiles) -> dict:
    """What the run chose and from which evaluations."""
    with np.load(files.evaluations) as saved:
        evaluations = {key: saved[key].tolist() for key in ("timesteps", "results", "ep_lengths")}
    return {
        "evaluations": evaluations,
        "best": json.loads(files.best_info.read_text()),
        "selected": json.loads(files.record.read_text())["selected"],
    }


def _same_weights(first: Path, second: Path) -> bool:
    a, b = read_saved_model(first).policy_state, read_saved_model(second).policy_state
    return a.keys() == b.keys() and all(torch.equal(a[name], b[name]) for name in a)


def _temporaries(files: RunFiles) -> list[str]:
    return [str(p.relative_to(files.run_dir)) for p in files.run_dir.rglob(".*")]


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory: pytest.TempPathFactory) -> RunFiles:
    tmp_path = tmp_path_factory.mktemp("uninterrupted")
    _, config_path = tiny_train_config(tmp_path, **CONFIG)
    assert _train(config_path, tmp_path / "runs") == 0
    return RunFiles.of(tmp_path / "runs", "tiny_ppo")


def test_the_resumed_run_redoes_nothing_when_nothing_failed(uninterrupted: RunFiles) -> None:
    outcome = _outcome(uninterrupted)
    assert outcome["evaluations"]["timesteps"] == [64]
    assert outcome["best"]["timesteps"] == 64 and outcome["selected"].endswith("at 64 steps")


@pytest.mark.parametrize("failing", ["best model", "evaluation history"])
def test_a_write_failing_after_an_evaluation_leaves_the_choice_of_an_uninterrupted_run(
    uninterrupted: RunFiles, tmp_path: Path, monkeypatch, capsys, failing: str
) -> None:
    _, config_path = tiny_train_config(tmp_path, **CONFIG)
    files = RunFiles.of(tmp_path / "runs", "tiny_ppo")
    failing_path = files.best_model if failing == "best model" else files.evaluations

    def full_disk(path: Path, *args: object) -> None:
        path.parent.mkdir(exist_ok=True)
        with replacing_atomically(path) as temporary:  # partway into the file, as a full disk stops it
            temporary.write_bytes(b"partial")
            raise OSError(errno.ENOSPC, "No space left on device")

    if failing == "best model":
        save = callbacks.save_atomically  # checkpoints are saved as before
        monkeypatch.setattr(
            callbacks,
            "save_atomically",
            lambda model, path: full_disk(path) if path == files.best_model else save(model, path),
        )
    else:
        monkeypatch.setattr(callbacks, "write_evaluations", full_disk)
    assert _train(config_path, files.run_dir.parent) == 1
    assert capsys.readouterr().err.strip() == f"flownav train: error: No space left on device: {failing_path}"
    session = json.loads(files.record.read_text())["sessions"][-1]
    assert session["status"] == FAILED
    assert session["error"] == f"OSError: [Errno 28] No space left on device: '{failing_path}'"
    assert _temporaries(files) == [] and not files.best_model.exists()
    assert files.evaluations.exists() == (failing == "best model")  # recorded before the best model

    monkeypatch.undo()
    assert _train(config_path, files.run_dir.parent, "--resume") == 0
    said = capsys.readouterr().out
    if failing == "best model":
        assert "the best evaluation, " in said and "had no best model saved: taken from" in said
    else:
        assert "redoing the evaluation at the resumed step 64, missing from" in said
    assert _outcome(files) == _outcome(uninterrupted)
    assert _same_weights(files.best_model, uninterrupted.best_model)
    statuses = [s["status"] for s in json.loads(files.record.read_text())["sessions"]]
    assert statuses == [FAILED, FINISHED] and _temporaries(files) == []


def _saved(tmp_path: Path, name: str, content: bytes) -> Path:
    path = tmp_path / "checkpoints" / name
    path.parent.mkdir(exist_ok=True)
    path.write_bytes(content)
    return path


def test_the_best_evaluation_takes_its_checkpoint_only_where_the_best_model_is_worse(
    tmp_path: Path, capsys
) -> None:
    files = RunFiles(tmp_path, "run")
    _saved(tmp_path, "run_128_steps.zip", b"model at 128")
    # The first of equal means is the best, as a new best must be strictly better.
    assert callbacks.restore_best(files, {64: 1.0, 128: 3.0, 192: 3.0}, (64, 1.0)) == 3.0
    assert files.best_model.read_bytes() == b"model at 128"
    assert json.loads(files.best_info.read_text()) == {"mean_return": 3.0, "timesteps": 128}
    assert (
        "the best evaluation, 3.00 at 128 steps, had no best model saved: taken from"
        in capsys.readouterr().out
    )

    # A better model from an evaluation dropped at the resume stays.
    assert callbacks.restore_best(files, {64: 1.0, 128: 3.0}, (256, 5.0)) == 5.0
    assert json.loads(files.best_info.read_text()) == {"mean_return": 5.0, "timesteps": 256}
    assert files.best_model.read_bytes() == b"model at 128"


def test_a_best_evaluation_without_its_checkpoint_keeps_the_saved_best_with_a_warning(
    tmp_path: Path, capsys
) -> None:
    files = RunFiles(tmp_path, "run")
    files.best_model.parent.mkdir()
    files.best_model.write_bytes(b"model at 64")  # its mean return unknown: taken from the evaluations
    assert callbacks.restore_best(files, {64: 1.0, 128: 3.0}, (64, None)) == 1.0
    assert capsys.readouterr().out.strip() == (
        "warning: the best evaluation, 3.00 at 128 steps, has no checkpoint left to be the best model; keeping "
        "the best model saved"
    )
    assert json.loads(files.best_info.read_text()) == {"mean_return": 1.0, "timesteps": 64}
    assert files.best_model.read_bytes() == b"model at 64"
    assert callbacks.restore_best(RunFiles(tmp_path / "none", "run"), {128: 3.0}, None) is None


LIMITED_TRAIN = """
import resource, signal, sys
from agents.training import callbacks

limit = int(sys.argv.pop(1))
save_checkpoint = callbacks.AtomicCheckpointCallback._on_step

def limit_file_size_after_the_last_checkpoint(self):
    kept = save_checkpoint(self)
    if self.num_timesteps >= 64:  # the disk fills right after the checkpoint of the evaluation's step
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # so that a write past the limit raises EFBIG
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, resource.RLIM_INFINITY))
    return kept

callbacks.AtomicCheckpointCallback._on_step = limit_file_size_after_the_last_checkpoint
from agents.cli import main
raise SystemExit(main())
"""


@pytest.mark.slow
def test_a_file_size_limit_at_the_best_models_save_leaves_the_choice_of_an_uninterrupted_run(
    uninterrupted: RunFiles, tmp_path: Path
) -> None:
    small = [uninterrupted.record, uninterrupted.evaluations, uninterrupted.best_info]
    small += list(uninterrupted.tensorboard.rglob("events*"))
    largest_small, model = max(p.stat().st_size for p in small), uninterrupted.best_model.stat().st_size
    assert largest_small * 2 < model, (largest_small, model)
    _, config_path = tiny_train_config(tmp_path, **CONFIG)
    runs_dir = tmp_path / "runs"
    files = RunFiles.of(runs_dir, "tiny_ppo")
    args = ["train", "--config", str(config_path), "--runs-dir", str(runs_dir)]
    limited = subprocess.run(
        [sys.executable, "-c", LIMITED_TRAIN, str((largest_small + model) // 2), *args],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert limited.returncode == 1, limited.stderr
    assert (
        limited.stderr.strip().splitlines()[-1] == f"flownav train: error: File too large: {files.best_model}"
    )
    session = json.loads(files.record.read_text())["sessions"][-1]
    assert session["status"] == FAILED and session["error"].startswith("OSError: [Errno 27] File too large")
    assert _temporaries(files) == []

    assert _train(config_path, runs_dir, "--resume") == 0
    assert _outcome(files) == _outcome(uninterrupted)
    assert _same_weights(files.best_model, uninterrupted.best_model)
    assert _temporaries(files) == []
