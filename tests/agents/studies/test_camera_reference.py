"""The camera-limited references' check on the closed field: the runs it makes, the CPU seconds it records beside
them, and the summary of the committed episodes as committed."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from agents.cli import main
from agents.studies import camera_reference
from agents.studies.camera_reference import AGENTS, COURSES, SUMMARY_CSV, evaluate_argv

COMMITTED = Path(__file__).resolve().parents[3] / "results" / "camera_reference"


def test_the_summary_of_the_committed_episodes_is_the_committed_summary(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    for path in [*COMMITTED.glob("*.csv"), *COMMITTED.glob("*.time")]:
        if path.name != SUMMARY_CSV:
            shutil.copy(path, tmp_path)
    assert main(["camera-reference", "--summary-only", "--out", str(tmp_path)]) == 0
    assert capsys.readouterr().out == f"wrote {tmp_path / SUMMARY_CSV}\n"
    assert (tmp_path / SUMMARY_CSV).read_text() == (COMMITTED / SUMMARY_CSV).read_text()


def test_each_agent_flies_each_course_in_a_process_of_its_own_with_its_times_beside_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    flown: list[list[str]] = []

    def fake_run(command: list[str], check: bool) -> None:
        assert check
        flown.append(command)

    monkeypatch.setattr(subprocess, "run", fake_run)
    written = camera_reference.fly_camera_reference(tmp_path, say=lambda line: None)
    runs = [(agent, course) for course in COURSES for agent in AGENTS]
    assert len(flown) == len(runs)
    for command, (agent, course) in zip(flown, runs, strict=True):
        argv = evaluate_argv(agent, course, tmp_path)
        assert command[-len(argv) :] == argv
    assert written == [tmp_path / f"{agent}_{course}.time" for agent, course in runs]
    assert all(len(path.read_text().split()) == 3 for path in written)
    assert evaluate_argv("planner", "hard", tmp_path)[-8:] == [
        "--env",
        "forward_speed=2.0",
        "--env",
        "obstacle_density=0.18",
        "--env",
        "depth_error_info=False",
        "--out",
        str(tmp_path / "planner_hard.csv"),
    ]
