"""What ``flownav score`` does with the folder it writes: a changed agent file named as the cause, ``--overwrite``
starting afresh, a damaged header repaired, damaged rows and rows of another suite version counted and flown
again, and what is there and left said before flying. One real flight of two tiers is shared; each test
starts from a copy of its CSV."""

from __future__ import annotations

import contextlib
import csv
import io
import shutil
from pathlib import Path

import pytest

from agents.analysis.csv_file import CHECKSUM_FIELD, csv_header, sealed_line
from agents.analysis.records import read_episodes, read_records
from agents.cli import main
from agents.common.seeds import suite_seeds
from agents.evaluation.suite import EPISODES_CSV
from flownav_env.tiers import SUITE_VERSION

AGENT_SOURCE = (
    "from agents.policies.reactive import StraightAgent\n\n\ndef make():\n    return StraightAgent()\n"
)
TIERS = ("clean", "hard")


def score_args(agent_file: Path, out: Path, *extra: str) -> list[str]:
    """``flownav score`` of the agent file's ``make`` on one layout of each of :data:`TIERS`."""
    return [
        "score",
        "--agent",
        f"{agent_file}:make",
        "--tiers",
        ",".join(TIERS),
        "--layouts",
        "1",
        "--workers",
        "1",
        "--out",
        str(out),
        *extra,
    ]


@pytest.fixture(scope="module")
def first_flight(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, str, str]:
    """The agent file (records name it by its path: every test scores this one), the episodes CSV of its
    first score into a fresh folder, and what that printed (stdout, stderr)."""
    folder = tmp_path_factory.mktemp("first")
    agent_file = folder / "agent.py"
    agent_file.write_text(AGENT_SOURCE)
    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        assert main(score_args(agent_file, folder / "out")) == 0
    return agent_file, folder / "out" / EPISODES_CSV, stdout.getvalue(), stderr.getvalue()


@pytest.fixture
def scored(first_flight: tuple[Path, Path, str, str], tmp_path: Path) -> tuple[Path, Path]:
    """(agent file, output folder in ``tmp_path`` holding a copy of the first flight's CSV)."""
    agent_file, csv_path = first_flight[:2]
    out = tmp_path / "out"
    out.mkdir()
    shutil.copy(csv_path, out / EPISODES_CSV)
    return agent_file, out


def lines_of(path: Path) -> list[bytes]:
    return path.read_bytes().splitlines(keepends=True)


def test_a_first_score_says_what_is_left_and_shows_a_bar_per_tier(
    first_flight: tuple[Path, Path, str, str],
) -> None:
    _, csv_path, stdout, stderr = first_flight
    assert (
        f"{csv_path} holds 0 of these 2 episodes already (clean 0/1, hard 0/1); 2 left to fly; each bar's time "
        "left is an estimate from the pace of its episodes flown so far"
    ) in stdout
    assert (
        "[progress]   clean: 1/1 episodes done in " in stderr
        and "[progress]   hard: 1/1 episodes done in " in stderr
    )
    assert len(read_records(csv_path)) == 2


def test_a_resumed_score_says_what_is_there_and_flies_nothing(
    scored: tuple[Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    agent_file, out = scored
    before = (out / EPISODES_CSV).read_bytes()
    assert main(score_args(agent_file, out)) == 0
    stdout = capsys.readouterr().out
    assert (
        f"{out / EPISODES_CSV} holds 2 of these 2 episodes already (clean 1/1, hard 1/1); 0 left to fly\n"
        in stdout
    )
    assert (out / EPISODES_CSV).read_bytes() == before


def test_an_edited_agent_file_is_named_and_overwrite_starts_afresh_keeping_the_old_file(
    scored: tuple[Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    agent_file, out = scored
    csv_path = out / EPISODES_CSV
    old = csv_path.read_bytes()
    agent_file.write_text(AGENT_SOURCE + "# tuned\n")
    try:
        edited = main(score_args(agent_file, out))
        error = capsys.readouterr().err.strip().splitlines()
        overwritten = main(score_args(agent_file, out, "--overwrite"))
    finally:
        agent_file.write_text(AGENT_SOURCE)  # the other tests' episodes are of the original file
    assert edited == 2
    assert len(error) == 1
    assert (
        "flown with other settings (your agent's file changed since these episodes were flown: " in error[0]
    )
    assert "write to another folder (--out), or start a new one with --overwrite" in error[0]
    assert overwritten == 0
    (backup,) = out.glob(f"{EPISODES_CSV}.bak-*")
    assert f"--overwrite: moved {csv_path} to {backup}" in capsys.readouterr().out
    assert backup.read_bytes() == old  # the refused run changed nothing; --overwrite kept it whole
    rows = read_records(csv_path)
    assert len(rows) == 2 and all(row["agent_params"] not in old.decode() for row in rows)


def test_a_damaged_header_is_repaired_keeping_every_checksummed_row(
    scored: tuple[Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    agent_file, out = scored
    csv_path = out / EPISODES_CSV
    header, *rows = lines_of(csv_path)
    damaged = bytes([header[0] ^ 0x01]) + header[1:]  # one flipped bit: "`gent,..." is no known header
    csv_path.write_bytes(damaged + b"".join(rows))
    assert main(score_args(agent_file, out)) == 0
    stdout = capsys.readouterr().out
    (backup,) = out.glob(f"{EPISODES_CSV}.bak-*")
    assert (
        f"{csv_path} had a damaged header: its 2 checksummed rows now sit under a correct header in a new "
        f"{EPISODES_CSV} (0 damaged rows left out); the damaged file is kept as {backup}\n"
    ) in stdout
    assert "holds 2 of these 2 episodes already" in stdout  # nothing flown again
    assert backup.read_bytes() == damaged + b"".join(rows)
    assert lines_of(csv_path) == [header, *rows]


def test_a_file_that_is_no_episodes_csv_is_still_refused_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    agent_file = tmp_path / "agent.py"
    agent_file.write_text(AGENT_SOURCE)
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / EPISODES_CSV).write_text("name,score\nmine,0.5\n")
    assert main(score_args(agent_file, tmp_path / "out")) == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1 and "is not a FlowNav episodes CSV: its header starts 'name,score'" in error[0]
    assert not list((tmp_path / "out").glob("*.bak-*"))


def test_damaged_rows_are_counted_and_flown_again(
    scored: tuple[Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    agent_file, out = scored
    csv_path = out / EPISODES_CSV
    header, first, second = lines_of(csv_path)
    csv_path.write_bytes(header + first + second.replace(b"False", b"Falsf", 1))  # its checksum now fails
    assert main(score_args(agent_file, out)) == 0
    stdout = capsys.readouterr().out
    assert (
        f"1 damaged rows in {csv_path} (torn, or failing their checksum) are left out; their episodes will be "
        "flown again"
    ) in stdout
    assert "holds 1 of these 2 episodes already" in stdout
    episodes = read_episodes(csv_path)
    assert len(episodes.rows) == 2 and episodes.skipped == 1


def test_rows_of_another_suite_version_are_left_out_and_flown_again(
    scored: tuple[Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    agent_file, out = scored
    csv_path = out / EPISODES_CSV
    header, first, second = lines_of(csv_path)
    columns = csv_header(header.rstrip(b"\r\n"))
    values = next(csv.reader([second.rstrip(b"\r\n").decode()]))
    values[columns.index("suite_version")] = "0.9"
    csv_path.write_bytes(header + first + sealed_line(values[: columns.index(CHECKSUM_FIELD)]).encode())
    assert main(score_args(agent_file, out)) == 0
    stdout = capsys.readouterr().out
    assert (
        f"1 rows in {csv_path} were flown under suite version '0.9', not the current {SUITE_VERSION!r}: they are "
        "left out and their episodes flown again"
    ) in stdout
    assert "holds 1 of these 2 episodes already" in stdout
    rows = read_records(csv_path)
    assert sorted(row["suite_version"] for row in rows) == sorted(["0.9", SUITE_VERSION, SUITE_VERSION])
    layout = suite_seeds(1)[0]
    assert sum(row["seed"] == layout and row["suite_version"] == SUITE_VERSION for row in rows) == 2
