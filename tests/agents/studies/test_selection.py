"""Finalist selection: a finished run's best held-out model and last checkpoint fly the same fresh validation
layouts of the run's block, the one with more successes becomes its policy, and the record says so."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import pytest
from helpers import tiny_train_config

from agents.analysis.records import read_records
from agents.cli import main
from agents.common.manifest import file_sha256
from agents.common.seeds import checkpoint_selection_seed
from agents.policies import UnverifiedPolicyWarning
from agents.studies.selection import FINALIST_SEED_OFFSET, finalist_seeds, finalists, select_finalist
from agents.training.multiseed import seed_jobs, train_seeds
from agents.training.outputs import RunFiles


def test_finalists_fly_fresh_validation_layouts_and_the_better_becomes_the_policy(tmp_path: Path) -> None:
    config, config_path = tiny_train_config(tmp_path, total=192, name="picky")
    runs_dir = tmp_path / "runs"
    train_seeds(seed_jobs(config, [1], config_path=config_path, runs_dir=runs_dir, ship_to=None))
    files = RunFiles.of_seed(runs_dir, "picky", 1)
    candidates = finalists(files)
    assert len(candidates) == 2 and "best held-out eval" in candidates

    with warnings.catch_warnings():
        warnings.simplefilter("error", UnverifiedPolicyWarning)  # select vouches for the copies it staged
        selected = select_finalist(files, 1, workers=1, episodes=3)
    rows = read_records(files.run_dir / "finalists" / "episodes.csv")
    seeds = finalist_seeds(1, 3)
    assert seeds[0] == checkpoint_selection_seed(1) + FINALIST_SEED_OFFSET
    assert sorted({int(r["seed"]) for r in rows}) == seeds
    hashes = {file_sha256(path) for path in candidates.values()}
    assert {r["policy_sha256"] for r in rows} == hashes and len(rows) == 3 * len(hashes)
    record = json.loads(files.record.read_text())
    assert record["selected"] == selected and selected.startswith("finalist on 3 validation layouts")
    assert record["selected_in_training"].startswith("best held-out eval")
    assert file_sha256(files.policy) in hashes
    # Again: nothing more is flown, and the same policy is chosen.
    assert select_finalist(files, 1, workers=1, episodes=3) == selected
    assert len(read_records(files.run_dir / "finalists" / "episodes.csv")) == len(rows)


def test_finalists_flown_before_the_run_trained_on_are_set_aside(tmp_path: Path, capsys) -> None:
    config, config_path = tiny_train_config(tmp_path, total=192, name="longer")
    runs_dir = tmp_path / "runs"
    train_seeds(seed_jobs(config, [0], config_path=config_path, runs_dir=runs_dir, ship_to=None))
    files = RunFiles.of_seed(runs_dir, "longer", 0)
    select_finalist(files, 0, workers=1, episodes=2)
    # As if the run had trained on: its best held-out model is now another file.
    last = next(path for label, path in finalists(files).items() if label.startswith("last"))
    files.best_model.write_bytes(last.read_bytes())
    selected = select_finalist(files, 0, workers=1, episodes=2)
    staging = files.run_dir / "finalists"
    assert "flown with other settings (other finalists: the run trained on since" in capsys.readouterr().out
    assert len(list(staging.glob("episodes.csv.bak-*"))) == 1
    rows = read_records(staging / "episodes.csv")
    assert {r["policy_sha256"] for r in rows} == {file_sha256(last)} and len(rows) == 2
    assert selected.startswith("finalist on 2 validation layouts") and file_sha256(
        files.policy
    ) == file_sha256(last)


def test_selecting_an_untrained_run_names_what_is_missing(tmp_path: Path, capsys) -> None:
    with pytest.raises(FileNotFoundError, match=r"is not a finished training run"):
        select_finalist(RunFiles.of_seed(tmp_path, "none", 0), 0)
    _, config_path = tiny_train_config(tmp_path, total=64, name="none")
    assert main(["select", "--config", str(config_path), "--workers", "0"]) == 2
    assert "--workers must be >= 1, got 0" in capsys.readouterr().err
