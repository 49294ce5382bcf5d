"""Progress where stderr is no terminal: plain whole lines, no carriage returns or cursor moves."""

from __future__ import annotations

import io

import pytest

from agents.evaluation import progress
from agents.evaluation.episode_tasks import EpisodeTask
from agents.evaluation.progress import PROGRESS_PREFIX, EpisodeProgress, PlainProgress, episode_progress


def tasks(counts: dict[str, int]) -> list[EpisodeTask]:
    return [
        EpisodeTask("bee", factor, 0.0, 2_000_000 + index, "FlowNav-v0", (), None)
        for factor, count in counts.items()
        for index in range(count)
    ]


def test_plain_progress_writes_whole_lines_a_tenth_at_a_time_and_each_factor_s_end() -> None:
    todo = tasks({"clean": 10, "hard": 10})
    stream = io.StringIO()
    plain = PlainProgress(todo, "score x", by_factor=True, stream=stream)
    for task in todo:
        plain.update(task.factor)
    plain.close()
    text = stream.getvalue()
    assert "\r" not in text and "\x1b" not in text
    lines = text.splitlines()
    assert all(line.startswith(PROGRESS_PREFIX) for line in lines)
    assert sum("score x: " in line for line in lines) == 10  # every tenth of 20 episodes
    assert lines[-1].startswith(f"{PROGRESS_PREFIX}score x: 20/20 episodes, 100 %, ")
    assert any(line.startswith(f"{PROGRESS_PREFIX}  clean: 10/10 episodes done in ") for line in lines)
    assert any(line.startswith(f"{PROGRESS_PREFIX}  hard: 10/10 episodes done in ") for line in lines)


def test_bars_on_a_terminal_plain_lines_elsewhere(monkeypatch: pytest.MonkeyPatch) -> None:
    todo = tasks({"clean": 2})
    monkeypatch.setattr(progress.sys.stderr, "isatty", lambda: False, raising=False)
    assert isinstance(episode_progress(todo, "x"), PlainProgress)
    monkeypatch.setattr(progress.sys.stderr, "isatty", lambda: True, raising=False)
    bars = episode_progress(todo, "x")
    assert isinstance(bars, EpisodeProgress)
    bars.close()
