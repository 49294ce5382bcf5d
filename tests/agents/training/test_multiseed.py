"""Several training seeds of one config: seed lists, disjoint worker layouts, the per-seed folders and
configs, skipping finished seeds and resuming the rest, and the command line's refusals."""

from __future__ import annotations

import itertools
import json
import multiprocessing
import re
import signal
import time
from pathlib import Path

import pytest
import yaml
from helpers import tiny_train_config

from agents.cli import main
from agents.common.seeds import (
    MAX_RUN_SEED,
    VALIDATION_SEED_START,
    checkpoint_selection_seed,
    training_env_seed,
)
from agents.training import multiseed
from agents.training.multiseed import finished, parse_seeds, seed_jobs, train_seeds
from agents.training.outputs import RunFiles


def test_seed_lists_take_ranges_and_lists_in_order_without_repeats() -> None:
    assert parse_seeds("0-4") == [0, 1, 2, 3, 4]
    assert parse_seeds("3, 0-1,3") == [3, 0, 1]
    assert parse_seeds("7") == [7]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("4-2", "--seeds takes N, N-M (N <= M) or a comma-separated list of them, got '4-2'"),
        ("a", "--seeds takes N, N-M"),
        ("0,,1", "--seeds takes N, N-M"),
        (f"0-{MAX_RUN_SEED + 1}", f"training seeds must lie in [0, {MAX_RUN_SEED}], got {MAX_RUN_SEED + 1}"),
    ],
)
def test_bad_seed_lists_are_refused(text: str, message: str) -> None:
    with pytest.raises(ValueError) as caught:
        parse_seeds(text)
    assert message in str(caught.value)


def test_runs_start_their_workers_on_disjoint_training_layouts() -> None:
    starts = [training_env_seed(seed) for seed in range(MAX_RUN_SEED + 1)]
    # Up to 64 workers per run (TrainConfig.n_envs) never reach the next run's first layout.
    assert all(b - a >= 64 for a, b in itertools.pairwise(starts))
    assert starts[-1] + 64 < VALIDATION_SEED_START
    assert VALIDATION_SEED_START <= checkpoint_selection_seed(MAX_RUN_SEED) < 1_000_000


def test_each_seed_trains_into_its_own_folder_and_a_finished_one_is_skipped(tmp_path: Path, capsys) -> None:
    config, config_path = tiny_train_config(tmp_path, total=64, name="multi")
    runs_dir, ship_to = tmp_path / "runs", tmp_path / "policies"
    jobs = seed_jobs(config, [0, 3], config_path=config_path, runs_dir=runs_dir, ship_to=ship_to)
    policies = train_seeds(jobs)
    assert policies == [
        runs_dir / "multi" / "seed_0" / "seed_0.zip",
        runs_dir / "multi" / "seed_3" / "seed_3.zip",
    ]
    for seed in (0, 3):
        files = RunFiles.of_seed(runs_dir, "multi", seed)
        assert yaml.safe_load(files.config.read_text())["seed"] == seed
        assert f"--seeds {seed}" in files.config.read_text().splitlines()[1]
        assert (ship_to / "multi" / f"seed_{seed}.zip").is_file()
        assert (ship_to / "multi" / f"seed_{seed}.yaml").is_file()
    assert all(finished(job) for job in jobs)
    record = RunFiles.of_seed(runs_dir, "multi", 3).record
    before = json.loads(record.read_text())
    capsys.readouterr()
    train_seeds(jobs)
    assert "seed 0: finished" in capsys.readouterr().out
    assert json.loads(record.read_text()) == before  # nothing trained again
    # A larger budget resumes each seed from its checkpoint instead of starting over.
    longer = seed_jobs(
        config.__class__(**{**config.__dict__, "total_timesteps": 128}),
        [3],
        config_path=config_path,
        runs_dir=runs_dir,
        ship_to=None,
    )
    assert not finished(longer[0])
    train_seeds(longer)
    assert "resuming from" in capsys.readouterr().out
    resumed = json.loads(record.read_text())
    assert resumed["total_timesteps"] == 128 and len(resumed["sessions"]) == 2


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--seeds", "0", "--resume"], "--seeds always resumes unfinished seeds: drop --resume"),
        (["--backend", "ray"], "--backend, --address and --parallel apply to --seeds runs only"),
        (["--parallel", "2"], "--backend, --address and --parallel apply to --seeds runs only"),
        (["--seeds", "0-1", "--parallel", "0"], "parallel must be an integer in [1, 64], got 0"),
        (
            ["--seeds", "0-1", "--parallel", "2", "--backend", "ray"],
            "parallel applies to the local backend only",
        ),
        (["--seeds", "2-1"], "--seeds takes N, N-M (N <= M)"),
    ],
)
def test_the_train_command_refuses_mixed_options(
    tmp_path: Path, capsys, extra: list[str], message: str
) -> None:
    _, config_path = tiny_train_config(tmp_path, total=64, name="refused")
    code = main(["train", "--config", str(config_path), "--runs-dir", str(tmp_path / "runs"), *extra])
    assert code == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "runs" / "refused").exists()


def test_an_unknown_backend_is_refused(tmp_path: Path) -> None:
    config, config_path = tiny_train_config(tmp_path, total=64, name="backend")
    jobs = seed_jobs(config, [0], config_path=config_path, runs_dir=tmp_path, ship_to=None)
    with pytest.raises(ValueError, match="backend must be 'local' or 'ray', got 'slurm'"):
        train_seeds(jobs, backend="slurm")


@pytest.mark.parametrize(
    ("parallel", "message"),
    [
        (0, "parallel must be an integer in [1, 64], got 0"),
        (65, "parallel must be an integer in [1, 64], got 65"),
        (True, "parallel must be an integer in [1, 64], got True"),
        (1.5, "parallel must be an integer in [1, 64], got 1.5"),
    ],
)
def test_bad_parallel_counts_are_refused(tmp_path: Path, parallel, message: str) -> None:
    config, config_path = tiny_train_config(tmp_path, total=64, name="parallel")
    jobs = seed_jobs(config, [0, 1], config_path=config_path, runs_dir=tmp_path, ship_to=None)
    with pytest.raises(ValueError) as caught:
        train_seeds(jobs, parallel=parallel)
    assert message in str(caught.value)
    assert not (tmp_path / "parallel").exists()


def test_seeds_side_by_side_train_exactly_what_they_train_in_turn(tmp_path: Path) -> None:
    import torch

    from agents.common.saved_models import read_saved_model

    config, config_path = tiny_train_config(tmp_path, total=64, name="sides", n_envs=2)
    in_turn, side_by_side = tmp_path / "in_turn", tmp_path / "side_by_side"
    train_seeds(seed_jobs(config, [0], config_path=config_path, runs_dir=in_turn, ship_to=None))
    jobs = seed_jobs(config, [0, 1], config_path=config_path, runs_dir=side_by_side, ship_to=None)
    train_seeds(jobs, parallel=2)
    for seed in (0, 1):
        record = json.loads(RunFiles.of_seed(side_by_side, "sides", seed).record.read_text())
        assert record["sessions"][-1]["env_workers"] == "in process"
    # The envs stepped in the seed's own process gave the same rollouts as one worker process per env.
    first = read_saved_model(RunFiles.of_seed(in_turn, "sides", 0).policy).policy_state
    second = read_saved_model(RunFiles.of_seed(side_by_side, "sides", 0).policy).policy_state
    assert first.keys() == second.keys()
    assert all(torch.equal(first[name], second[name]) for name in first)
    other = read_saved_model(RunFiles.of_seed(side_by_side, "sides", 1).policy).policy_state
    assert not all(torch.equal(first[name], other[name]) for name in first)


def test_a_run_without_a_progress_bar_prints_progress_lines(tmp_path: Path, capsys) -> None:
    from agents.training.ppo import train

    config, config_path = tiny_train_config(tmp_path, total=128, name="lines")
    train(config, config_path=config_path, resume=False, runs_dir=tmp_path / "runs", progress_bar=False)
    output = capsys.readouterr().out
    assert "lines seed 0: 64 / 128 steps (" in output and "lines seed 0: 128 / 128 steps (" in output


def test_sigterm_saves_the_seed_and_stops_before_the_next_even_in_the_background(tmp_path: Path) -> None:
    import signal
    import subprocess
    import sys
    import time

    _, config_path = tiny_train_config(tmp_path, total=100_000, name="stopped")
    runs_dir = tmp_path / "runs"
    # As `cmd &` in a script starts it: SIGINT ignored, so only SIGTERM (or an explicit handler) can stop it.
    process = subprocess.Popen(
        [sys.executable, "-c", "from agents.cli import main; raise SystemExit(main())", "train", "--config",
         str(config_path), "--seeds", "0-1",
         "--runs-dir", str(runs_dir)],
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )  # fmt: skip
    files = RunFiles.of_seed(runs_dir, "stopped", 0)
    deadline = time.monotonic() + 120
    while (
        not (files.checkpoints.is_dir() and any(files.checkpoints.iterdir())) and time.monotonic() < deadline
    ):
        time.sleep(0.5)
    process.send_signal(signal.SIGTERM)
    output, _ = process.communicate(timeout=120)
    assert process.returncode == 130, output
    assert re.search(
        rf"interrupted: seed 0 saved at [\d,]+ steps in {re.escape(str(files.run_dir))}; run the same command "
        "to resume",
        output,
    ), output
    record = json.loads(files.record.read_text())
    assert record["sessions"][-1]["interrupted"] is True
    assert not (runs_dir / "stopped" / "seed_1").exists()


def test_a_parked_seed_resumes_in_a_new_checkout_and_its_parked_copy_goes(tmp_path: Path, capsys) -> None:
    import shutil

    from agents.training.multiseed import park_seeds

    config, config_path = tiny_train_config(tmp_path, total=64, name="parked")
    runs_dir, parked_dir = tmp_path / "runs", tmp_path / "unfinished"
    train_seeds(seed_jobs(config, [0], config_path=config_path, runs_dir=runs_dir, ship_to=None))
    # A larger budget makes the seed unfinished, as the end of a session leaves it.
    longer = config.__class__(**{**config.__dict__, "total_timesteps": 128})
    jobs = seed_jobs(
        longer, [0, 1], config_path=config_path, runs_dir=runs_dir, ship_to=None, parked_dir=parked_dir
    )
    assert park_seeds(jobs) == [parked_dir / "parked" / "seed_0"]
    output = capsys.readouterr().out
    assert "seed 0: parked" in output and "seed 1: " in output and "no readable checkpoint" in output
    parked = RunFiles.of_seed(parked_dir, "parked", 0)
    assert [p.name for p in parked.checkpoints.iterdir()] == ["parked_64_steps.zip"]
    assert parked.record.is_file() and parked.evaluations.is_file() and parked.best_model.is_file()
    shutil.rmtree(runs_dir)  # the new checkout: runs/ is gone, results/unfinished/ was committed
    train_seeds(jobs[:1])
    assert "seed 0: restored from" in capsys.readouterr().out
    record = json.loads(RunFiles.of_seed(runs_dir, "parked", 0).record.read_text())
    assert record["total_timesteps"] == 128 and len(record["sessions"]) == 2
    assert not (parked_dir / "parked").exists()  # finished: the parked copy is removed


def test_parking_refuses_what_it_cannot_park(tmp_path: Path, capsys) -> None:
    from agents.training.multiseed import park_seeds

    config, config_path = tiny_train_config(tmp_path, total=64, name="parked")
    runs_dir = tmp_path / "runs"
    finished_jobs = seed_jobs(
        config, [0], config_path=config_path, runs_dir=runs_dir, ship_to=None, parked_dir=tmp_path / "u"
    )
    train_seeds(finished_jobs)
    capsys.readouterr()
    assert park_seeds(finished_jobs) == []
    assert "seed 0: finished; nothing to park (ship it)" in capsys.readouterr().out
    with pytest.raises(ValueError, match="seed 0: no parking folder given"):
        park_seeds(seed_jobs(config, [0], config_path=config_path, runs_dir=runs_dir, ship_to=None))
    code = main(["train", "--config", str(config_path), "--park"])
    assert code == 2
    assert "--park takes --seeds and no shipping options" in capsys.readouterr().err


def test_sigterm_saves_every_seed_side_by_side_and_starts_no_other(tmp_path: Path) -> None:
    import signal
    import subprocess
    import sys
    import time

    _, config_path = tiny_train_config(tmp_path, total=100_000, name="stopped")
    runs_dir = tmp_path / "runs"
    process = subprocess.Popen(
        [sys.executable, "-c", "from agents.cli import main; raise SystemExit(main())", "train", "--config",
         str(config_path), "--seeds", "0-2", "--parallel", "2", "--runs-dir", str(runs_dir)],
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )  # fmt: skip
    seeds = [RunFiles.of_seed(runs_dir, "stopped", seed) for seed in (0, 1)]
    deadline = time.monotonic() + 180
    while time.monotonic() < deadline and not all(
        files.checkpoints.is_dir() and any(files.checkpoints.iterdir()) for files in seeds
    ):
        time.sleep(0.5)
    process.send_signal(signal.SIGTERM)
    output, _ = process.communicate(timeout=120)
    assert process.returncode == 130, output
    for files in seeds:
        assert json.loads(files.record.read_text())["sessions"][-1]["interrupted"] is True
    assert not (runs_dir / "stopped" / "seed_2").exists()


def _sleep_deaf_to_sigterm() -> None:
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    time.sleep(60)


def test_seeds_left_running_after_an_error_in_the_loop_are_ended_within_the_bound(monkeypatch) -> None:
    monkeypatch.setattr(multiseed, "SEED_STOP_WAIT_S", 0.5)
    seeds = multiseed._SeedProcesses([], parallel=2)
    deaf = multiprocessing.get_context("fork").Process(target=_sleep_deaf_to_sigterm)  # a seed that hangs
    deaf.start()
    time.sleep(0.5)  # its handler is set
    seeds.running[0] = deaf
    started = time.monotonic()
    seeds.terminate_running()
    assert time.monotonic() - started < 2.0
    assert deaf.exitcode == -signal.SIGKILL
