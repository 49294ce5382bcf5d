"""Runs writing one episodes CSV at once: each episode is claimed before it flies and written once; readers
keep one row per episode and say how many duplicates they dropped."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import pytest

from agents.analysis.csv_file import LINE_END
from agents.analysis.records import append_record, episode_identity, read_episodes
from agents.analysis.statistics import summarise
from agents.common.seeds import TEST_SEED_START
from agents.evaluation import claims
from agents.evaluation.claims import (
    CLAIMED,
    FLOWN,
    MINE,
    claim_episode,
    claims_path,
    identity_digest,
    release_claims,
)
from agents.evaluation.episode import EpisodeRecord
from agents.evaluation.episode_tasks import EpisodeTask
from agents.evaluation.runner import execute

SMALL = (("camera_height", 72), ("camera_width", 96))
TASKS = [
    EpisodeTask("straight", "clean", 0.0, TEST_SEED_START + k, "FlowNavSingle-v0", SMALL) for k in range(4)
]


def record_of(task: EpisodeTask, steps: int = 10) -> EpisodeRecord:
    numbers = dict.fromkeys(("progress_m", "time_s", "min_clearance_m", "path_length_m"), 1.0)
    return EpisodeRecord(
        task.agent, task.factor, task.level, task.seed, True, False, False, False,
        steps=steps, mean_points_valid=1.0, median_depth_error=0.1, episode_return=-1.0, **numbers,
        **task.identity(), code_version="test",
    )  # fmt: skip


def identity_of(task: EpisodeTask) -> tuple:
    return episode_identity({**vars(task), **task.identity()})


def test_the_same_episode_is_appended_once(tmp_path: Path) -> None:
    path = tmp_path / "episodes.csv"
    assert append_record(path, record_of(TASKS[0]))
    # Another run's record of the same episode (even with other outcomes) is not added again.
    assert not append_record(path, record_of(TASKS[0], steps=99))
    assert append_record(path, record_of(TASKS[1]))
    assert len(path.read_text().splitlines()) == 3
    assert [row["steps"] for row in read_episodes(path).rows] == [10, 10]


def test_readers_keep_one_row_per_episode_and_say_how_many_they_dropped(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "episodes.csv"
    for task in TASKS[:2]:
        append_record(path, record_of(task))
    lines = path.read_text().splitlines(keepends=True)
    # What two processes deciding once at start used to leave: every row twice.
    path.write_text("".join(lines + lines[1:]), newline="")
    episodes = read_episodes(path)
    assert [row["seed"] for row in episodes.rows] == [TASKS[0].seed, TASKS[1].seed]
    assert episodes.duplicates == 2 and episodes.skipped == 0
    assert "2 duplicate rows dropped" in capsys.readouterr().err
    assert summarise(episodes.rows)[0]["episodes"] == 2


def test_the_same_seed_with_other_settings_is_not_a_duplicate(tmp_path: Path) -> None:
    path = tmp_path / "episodes.csv"
    append_record(path, record_of(TASKS[0]))
    other = replace(TASKS[0], env_kwargs=(*SMALL, ("brightness", 0.5)))
    assert append_record(path, record_of(other))
    assert read_episodes(path).duplicates == 0


def test_a_claimed_episode_is_left_to_its_live_claimant(tmp_path: Path) -> None:
    path = tmp_path / "episodes.csv"
    identity = identity_of(TASKS[0])
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    try:
        claims_path(path).write_text(
            f"{socket.gethostname()} {sleeper.pid} {time.time():.0f} {identity_digest(identity)}\n"
        )
        assert claim_episode(path, identity) == CLAIMED  # another live process flies it
        assert claim_episode(path, identity_of(TASKS[1])) == MINE
    finally:
        sleeper.kill()
        sleeper.wait()
    claims.CLAIMS_READS.reads.clear()  # a fresh process: it reads the claims file anew
    assert claim_episode(path, identity) == MINE  # its claimant died without writing it: fly it here


def test_an_expired_claim_counts_for_nothing(tmp_path: Path) -> None:
    path = tmp_path / "episodes.csv"
    identity = identity_of(TASKS[0])
    old = time.time() - claims.CLAIM_EXPIRY_S - 1
    claims_path(path).write_text(
        f"{socket.gethostname()} {os.getppid()} {old:.0f} {identity_digest(identity)}\n"
    )
    assert claim_episode(path, identity) == MINE


def test_an_episode_in_the_csv_is_not_claimed_again(tmp_path: Path) -> None:
    path = tmp_path / "episodes.csv"
    append_record(path, record_of(TASKS[0]))
    assert claim_episode(path, identity_of(TASKS[0])) == FLOWN
    release_claims(path)
    assert not claims_path(path).exists()


def test_claims_of_a_live_other_run_outlast_this_runs_release(tmp_path: Path) -> None:
    path = tmp_path / "episodes.csv"
    claims_path(path).write_text(
        f"{socket.gethostname()} {os.getppid()} {time.time():.0f} {identity_digest(identity_of(TASKS[0]))}\n"
    )
    release_claims(path)
    assert claims_path(path).exists()


def test_a_run_skips_what_another_run_flew_meanwhile(tmp_path: Path, monkeypatch) -> None:
    """The check happens before each episode, not once at start: rows written by another process after this
    run began are not flown again."""
    path = tmp_path / "episodes.csv"
    flown: list[int] = []

    def fly(task: EpisodeTask) -> EpisodeRecord:
        flown.append(task.seed)
        if task.seed == TASKS[0].seed:  # meanwhile, another run writes episode 2
            append_record(path, record_of(TASKS[2]))
        return record_of(task)

    monkeypatch.setattr("agents.evaluation.runner.run_task", fly)
    assert execute(TASKS, path) == 3
    assert flown == [TASKS[0].seed, TASKS[1].seed, TASKS[3].seed]
    assert sorted(row["seed"] for row in read_episodes(path).rows) == [task.seed for task in TASKS]
    assert not claims_path(path).exists()


def test_two_evaluations_at_once_write_each_episode_once(tmp_path: Path) -> None:
    out = tmp_path / "episodes.csv"
    command = [
        sys.executable, "-c", "import sys; from agents.cli import main; sys.exit(main())", "evaluate", "--agent", "straight", "--layouts", "4",
        "--tiers", "FlowNavSingle-v0", "--env", "camera_width=96", "--env", "camera_height=72", "--out", str(out),
    ]  # fmt: skip
    environment = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    runs = [subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=environment)
            for _ in range(2)]  # fmt: skip
    outputs = [run.communicate(timeout=300) for run in runs]
    assert [run.returncode for run in runs] == [0, 0], outputs
    lines = out.read_text().split(LINE_END)
    assert lines[0].startswith("agent,factor") and sum(line.startswith("agent,") for line in lines) == 1
    episodes = read_episodes(out)
    assert sorted(row["seed"] for row in episodes.rows) == [TEST_SEED_START + k for k in range(4)]
    assert episodes.duplicates == 0
    for stdout, _ in outputs:  # each run's summary counts the four episodes once, whoever flew them
        assert "| straight |" in stdout and "| 4 |" in stdout, stdout
