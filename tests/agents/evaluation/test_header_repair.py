"""An episodes CSV whose header is damaged or gone keeps its checksummed rows under a correct header; the
damaged file is kept aside, and a file of another kind is left alone."""

from __future__ import annotations

from pathlib import Path

import pytest

from agents.analysis.records import append_record, read_episodes, repair_episodes_header
from agents.evaluation.episode import EpisodeRecord


def record(seed: int) -> EpisodeRecord:
    numbers = dict.fromkeys(("progress_m", "time_s", "min_clearance_m", "path_length_m"), 1.0)
    return EpisodeRecord(
        "straight", "clean", 0.0, seed, True, False, False, False,
        steps=10, mean_points_valid=1.0, median_depth_error=0.1, episode_return=-1.0, **numbers,
        env_id="FlowNav-v0", env_kwargs="{}", agent_params="{}", policy_sha256="", code_version="test",
    )  # fmt: skip


@pytest.fixture
def episodes(tmp_path: Path) -> Path:
    path = tmp_path / "episodes.csv"
    for seed in range(3):
        append_record(path, record(seed))
    return path


def test_a_missing_header_is_written_back_and_every_row_kept(episodes: Path) -> None:
    header, *rows = episodes.read_bytes().splitlines(keepends=True)
    episodes.write_bytes(b"".join(rows))
    message = repair_episodes_header(episodes)
    (backup,) = episodes.parent.glob("episodes.csv.bak-*")
    assert message == (
        f"{episodes} had a damaged header: its 3 checksummed rows now sit under a correct header in a new "
        f"episodes.csv (0 damaged rows left out); the damaged file is kept as {backup}"
    )
    assert episodes.read_bytes() == header + b"".join(rows)
    assert backup.read_bytes() == b"".join(rows)


def test_a_damaged_header_and_a_torn_row_leave_the_whole_rows(episodes: Path) -> None:
    header, *rows = episodes.read_bytes().splitlines(keepends=True)
    episodes.write_bytes(header.replace(b"seed", b"sed") + rows[0] + rows[1][:20] + b"\r\n" + rows[2])
    message = repair_episodes_header(episodes) or ""
    assert "its 2 checksummed rows now sit under a correct header" in message
    assert "(1 damaged rows left out)" in message
    assert [row["seed"] for row in read_episodes(episodes).rows] == [0, 2]


def test_an_intact_file_and_a_foreign_file_are_left_alone(episodes: Path, tmp_path: Path) -> None:
    intact = episodes.read_bytes()
    assert repair_episodes_header(episodes) is None and episodes.read_bytes() == intact
    foreign = tmp_path / "scores.csv"
    foreign.write_text("name,score\nmine,0.5\n")
    assert repair_episodes_header(foreign) is None
    with pytest.raises(
        ValueError, match=r"scores\.csv is not a FlowNav episodes CSV: its header starts 'name,score'"
    ):
        read_episodes(foreign)
    assert not list(tmp_path.glob("*.bak-*"))
