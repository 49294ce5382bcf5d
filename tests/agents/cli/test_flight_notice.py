"""A command that would fly for more than a few minutes without being asked says so first, and how to ask for
less; a short flight says nothing."""

from __future__ import annotations

from pathlib import Path

import pytest

from agents.cli import main
from agents.cli.arguments import EPISODE_SECONDS, NOTICE_MINUTES, flight_notice
from agents.evaluation import scoring, suite
from agents.pages import suite_writer


def test_a_long_flight_is_announced_with_how_to_ask_for_less() -> None:
    episodes = int(NOTICE_MINUTES * 60 / EPISODE_SECONDS) * 2 + 2
    assert flight_notice("x", episodes, 2, "ask for less") == (
        f"flownav x: up to {episodes:,} episodes, about {episodes * EPISODE_SECONDS / 120:.0f} minutes with 2 "
        "workers (episodes already in the folder are not flown again); ask for less"
    )
    assert flight_notice("x", 10, 2, "ask for less") is None


def test_the_leaderboard_without_include_says_what_it_would_fly(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr("agents.cli.leaderboard.run_leaderboard", lambda *args, **kwargs: None)
    monkeypatch.setattr("agents.pages.leaderboard_page.write_leaderboard_page", lambda *args, **kwargs: [])
    assert main(["leaderboard", "--out", str(tmp_path)]) == 0
    (line,) = [
        line for line in capsys.readouterr().out.splitlines() if line.startswith("flownav leaderboard: ")
    ]
    assert "episodes, about" in line and "--include runs/score/score.csv sets your rows" in line
    assert main(["leaderboard", "--agents", "straight", "--layouts", "30", "--out", str(tmp_path)]) == 0
    assert "flownav leaderboard: up to" not in capsys.readouterr().out


def test_score_and_suite_say_what_they_would_fly(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(scoring, "score", lambda *args, **kwargs: [])
    monkeypatch.setattr(suite, "run_suite", lambda *args, **kwargs: None)
    monkeypatch.setattr(suite_writer, "write_suite_page", lambda *args, **kwargs: [])
    assert main(["score", "--agent", "bee", "--out", str(tmp_path)]) == 0
    assert "flownav score: up to 1,200 episodes" in capsys.readouterr().out
    assert main(["score", "--agent", "bee", "--layouts", "10", "--out", str(tmp_path)]) == 0
    assert "up to" not in capsys.readouterr().out
    assert main(["suite", "--out", str(tmp_path)]) == 0
    assert "flownav suite: up to" in capsys.readouterr().out
