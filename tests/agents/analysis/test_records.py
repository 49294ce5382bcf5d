"""The episodes CSV on disk: typed and checksummed rows, one header under concurrent appends, refused targets."""

from __future__ import annotations

import multiprocessing
from dataclasses import replace
from pathlib import Path

import pytest
from helpers import EPISODE

from agents.analysis.csv_file import LEGACY_FIELDS, sealed_line
from agents.analysis.records import (
    CSV_FIELDS,
    EARLIER_CSV_FIELDS,
    PREVIOUS_CSV_FIELDS,
    append_record,
    drop_agents,
    episode_key,
    read_episodes,
    read_records,
    start_new_file,
)

RECORD = EPISODE
LEGACY_ROW = "straight,clean,0.0,1000000,True,False,False,False,3.87,3.9,39,0.19,3.77,127.9,0.046,-6.125"


def write_legacy(path: Path, *rows: str) -> None:
    path.write_text("\r\n".join([",".join(LEGACY_FIELDS), *rows]) + "\r\n")


def test_rows_round_trip_with_their_identity_and_checksum(tmp_path: Path) -> None:
    path = tmp_path / "episodes.csv"
    append_record(path, RECORD)
    append_record(path, replace(RECORD, seed=1_000_001, median_depth_error=float("nan")))
    lines = path.read_text().splitlines()
    assert lines[0] == ",".join(CSV_FIELDS) and CSV_FIELDS[-1] == "row_crc"
    rows = read_records(path)
    assert [r["seed"] for r in rows] == [1_000_000, 1_000_001]
    assert rows[0]["env_kwargs"] == RECORD.env_kwargs and rows[0]["collision"] is True
    assert rows[1]["median_depth_error"] != rows[1]["median_depth_error"]  # nan survives


def test_a_file_from_before_the_outlier_share_keeps_its_columns_when_resumed(tmp_path: Path) -> None:
    # Committed leaderboard, ablation and tuning CSVs predate mean_depth_outlier_share: resuming into them must
    # neither be refused nor fly their episodes again.
    added = ["mean_depth_outlier_share", "suite_version", "max_abs_lateral_m", "isolation", "cpu"]
    assert [*PREVIOUS_CSV_FIELDS[:-1], *added, "row_crc"] == CSV_FIELDS
    append_record(tmp_path / "new.csv", replace(RECORD, mean_depth_outlier_share=0.25))
    assert read_records(tmp_path / "new.csv")[0]["mean_depth_outlier_share"] == 0.25
    old = tmp_path / "old.csv"
    previous_values = [str(getattr(RECORD, name)) for name in PREVIOUS_CSV_FIELDS[:-1]]
    old.write_text(",".join(PREVIOUS_CSV_FIELDS) + "\r\n" + sealed_line(previous_values), newline="")
    append_record(old, replace(RECORD, seed=1_000_001, mean_depth_outlier_share=0.25))
    lines = old.read_text().splitlines()
    assert lines[0] == ",".join(PREVIOUS_CSV_FIELDS) and len(lines) == 3
    rows = read_records(old)
    assert [r["seed"] for r in rows] == [1_000_000, 1_000_001]
    assert [r["mean_depth_outlier_share"] for r in rows] == [None, None]  # unknown in that format
    assert [r["suite_version"] for r in rows] == [None, None]


def test_a_file_from_before_the_suite_version_keeps_its_columns_when_resumed(tmp_path: Path) -> None:
    before_suite = EARLIER_CSV_FIELDS[1]
    later = ("suite_version", "max_abs_lateral_m", "isolation", "cpu")
    assert before_suite == [name for name in CSV_FIELDS if name not in later]
    old = tmp_path / "old.csv"
    values = [str(getattr(RECORD, name)) for name in before_suite[:-1]]
    old.write_text(",".join(before_suite) + "\r\n" + sealed_line(values), newline="")
    assert append_record(old, replace(RECORD, seed=1_000_001, suite_version="1"))
    assert old.read_text().splitlines()[0] == ",".join(before_suite)
    rows = read_records(old)
    assert [r["seed"] for r in rows] == [1_000_000, 1_000_001]
    assert [r["suite_version"] for r in rows] == [None, None]
    append_record(tmp_path / "new.csv", replace(RECORD, suite_version="1"))
    assert read_records(tmp_path / "new.csv")[0]["suite_version"] == "1"
    assert rows[1]["env_kwargs"] == RECORD.env_kwargs


def test_a_suite_file_from_before_the_lateral_extent_keeps_its_columns_when_resumed(tmp_path: Path) -> None:
    before_lateral = EARLIER_CSV_FIELDS[2]
    assert before_lateral == [
        name for name in CSV_FIELDS if name not in ("max_abs_lateral_m", "isolation", "cpu")
    ]
    old = tmp_path / "suite.csv"
    values = [str(getattr(RECORD, name)) for name in before_lateral[:-1]]
    old.write_text(",".join(before_lateral) + "\r\n" + sealed_line(values), newline="")
    assert append_record(old, replace(RECORD, seed=1_000_001, max_abs_lateral_m=4.8))
    assert old.read_text().splitlines()[0] == ",".join(before_lateral)
    assert [r["max_abs_lateral_m"] for r in read_records(old)] == [None, None]  # unknown in that format
    append_record(tmp_path / "new.csv", replace(RECORD, max_abs_lateral_m=4.8))
    assert read_records(tmp_path / "new.csv")[0]["max_abs_lateral_m"] == 4.8


def test_a_torn_last_row_is_skipped_wherever_it_was_cut(tmp_path: Path) -> None:
    path = tmp_path / "episodes.csv"
    append_record(path, RECORD)
    whole = path.read_text().splitlines()[1]
    cut_after_last_comma = whole[: whole.rindex(",") + 1]
    cut_inside_last_field = whole[:-3]
    tampered = whole.replace("3.87", "9.87")
    for offset, torn in enumerate((cut_after_last_comma, cut_inside_last_field, tampered), start=1):
        with path.open("a", newline="") as handle:
            handle.write(torn)  # an interrupted write: no line end
        # ends the torn line, adds a whole row
        append_record(path, replace(RECORD, seed=RECORD.seed + offset))
    episodes = read_episodes(path)
    assert [r["seed"] for r in episodes.rows] == [RECORD.seed + offset for offset in range(4)]
    assert episodes.skipped == 3


def test_legacy_rows_are_checked_by_type_and_have_unknown_identity(tmp_path: Path) -> None:
    path = tmp_path / "old.csv"
    write_legacy(
        path,
        LEGACY_ROW,
        LEGACY_ROW.rsplit(",", 1)[0] + ",",  # cut right after its last comma: was `could not convert ''`
        LEGACY_ROW.replace("True", "Tru", 1),  # not a bool
        LEGACY_ROW.replace(",39,", ",3.9,"),  # not an int
        LEGACY_ROW.replace("straight", "", 1),  # no agent
    )
    episodes = read_episodes(path)
    assert episodes.legacy and episodes.skipped == 4
    (row,) = episodes.rows
    assert row["episode_return"] == -6.125 and row["steps"] == 39
    assert row["env_id"] is None and row["policy_sha256"] is None  # unknown, not "reactive"


def test_appending_to_a_legacy_csv_is_refused_with_the_way_out(tmp_path: Path) -> None:
    path = tmp_path / "old.csv"
    write_legacy(path, LEGACY_ROW)
    with pytest.raises(ValueError, match=r"old.csv predates episode identities .*rename the file"):
        append_record(path, RECORD)


def _append_many(path: str, worker: int, start: multiprocessing.synchronize.Barrier, count: int) -> None:
    start.wait()  # every process finds the file missing at once
    for index in range(count):
        append_record(Path(path), replace(RECORD, seed=1_000_000 + 1000 * worker + index))


def test_processes_appending_to_a_new_csv_at_once_write_one_header_and_whole_rows(tmp_path: Path) -> None:
    path = tmp_path / "episodes.csv"
    workers, count = 6, 15
    context = multiprocessing.get_context("spawn")
    start = context.Barrier(workers)
    processes = [
        context.Process(target=_append_many, args=(str(path), worker, start, count))
        for worker in range(workers)
    ]
    for process in processes:
        process.start()
    for process in processes:
        process.join(timeout=120)
        assert process.exitcode == 0
    lines = path.read_text().splitlines()
    assert sum(line.startswith("agent,") for line in lines) == 1 and lines[0].startswith("agent,")
    episodes = read_episodes(path)
    assert episodes.skipped == 0 and len(episodes.rows) == workers * count
    assert len({r["seed"] for r in episodes.rows}) == workers * count


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (
            b"name,score\r\nalice,3\r\n",
            r"foreign.csv is not a FlowNav episodes CSV: its header starts 'name,score'",
        ),
        (
            b"\x89PNG\r\n\x1a\n\x00\xff\xfe",
            r"foreign.csv is not an episodes CSV \(its first line is not UTF-8 text",
        ),
        (None, r"foreign.csv is a directory, not an episodes CSV"),
    ],
)
def test_a_foreign_binary_or_directory_out_is_one_error_naming_it(
    tmp_path: Path, capsys, content: bytes | None, message: str
) -> None:
    from agents.cli import main

    target = tmp_path / "foreign.csv"
    if content is None:
        target.mkdir()
    else:
        target.write_bytes(content)
    with pytest.raises(ValueError, match=message):
        read_records(target)
    with pytest.raises(ValueError, match=message):
        append_record(target, RECORD)
    args = ["evaluate", "--agent", "straight", "--layouts", "1", "--tiers", "FlowNavSingle-v0"]
    assert main([*args, "--out", str(target)]) == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1 and error[0].startswith("flownav evaluate: error: ") and str(target) in error[0]
    if content is not None:
        assert target.read_bytes() == content  # nothing appended under a foreign header


def test_overwrite_moves_the_old_file_aside_and_never_over_a_backup(tmp_path: Path) -> None:
    path = tmp_path / "episodes.csv"
    assert start_new_file(path) is None  # nothing to move
    append_record(path, RECORD)
    first_bytes = path.read_bytes()
    first = start_new_file(path)
    append_record(path, replace(RECORD, seed=2))
    second = start_new_file(path)
    assert first != second and not path.exists()
    assert first.read_bytes() == first_bytes and first.name.startswith("episodes.csv.bak-")
    assert read_records(second)[0]["seed"] == 2


def test_drop_agents_keeps_checksummed_rows_readable(tmp_path: Path) -> None:
    path = tmp_path / "episodes.csv"
    append_record(path, RECORD)
    append_record(path, replace(RECORD, agent="bee"))
    assert drop_agents(path, ["bee"]) == 1
    assert [r["agent"] for r in read_records(path)] == ["straight"]


def test_a_flipped_byte_costs_only_its_own_row(tmp_path: Path) -> None:
    path = tmp_path / "episodes.csv"
    for offset in range(3):
        append_record(path, replace(RECORD, seed=RECORD.seed + offset))
    data = bytearray(path.read_bytes())
    second_row = data.index(b"\n", data.index(b"\n") + 1) + 1
    data[second_row + 3] = 0xFF  # not UTF-8 any more: before, the whole file was refused
    path.write_bytes(bytes(data))
    episodes = read_episodes(path)
    assert [row["seed"] for row in episodes.rows] == [RECORD.seed, RECORD.seed + 2]
    assert episodes.skipped == 1
    # Rewriting the file (dropping an agent) keeps the corrupt row's bytes as they were.
    assert drop_agents(path, ["bee"]) == 0
    assert path.read_bytes() == bytes(data)
    # Appending still works, and the corrupt row's episode can be flown again.
    append_record(path, replace(RECORD, seed=RECORD.seed + 1))
    assert sorted(row["seed"] for row in read_episodes(path).rows) == [RECORD.seed + k for k in range(3)]


def test_a_full_disk_is_one_error_naming_the_file_and_keeps_the_rows(tmp_path: Path) -> None:
    """A real file-size limit (RLIMIT_FSIZE) in a child process: the append fails with EFBIG."""
    import subprocess
    import sys

    path = tmp_path / "episodes.csv"
    append_record(path, RECORD)
    before = path.read_bytes()
    script = (
        "import resource, signal, sys\n"
        "from dataclasses import replace\n"
        "from pathlib import Path\n"
        "from agents.analysis.records import append_record\n"
        "from tests_record import RECORD\n"
        "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
        f"resource.setrlimit(resource.RLIMIT_FSIZE, ({len(before) + 10}, resource.RLIM_INFINITY))\n"
        "try:\n"
        f"    append_record(Path({str(path)!r}), replace(RECORD, seed=RECORD.seed + 1))\n"
        "except OSError as error:\n"
        "    print(error)\n"
        "    sys.exit(3)\n"
    )
    (tmp_path / "tests_record.py").write_text(
        f"from math import nan\nfrom agents.evaluation.episode import EpisodeRecord\nRECORD = {RECORD!r}\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", script], cwd=tmp_path, capture_output=True, text=True, timeout=60
    )
    assert result.returncode == 3, result.stderr
    assert "cannot add an episode: File too large" in result.stdout and str(path) in result.stdout
    assert read_records(path)[0]["seed"] == RECORD.seed  # what was written stays readable


def test_episodes_recorded_before_the_exclusive_rule_are_read_with_one_outcome(tmp_path: Path) -> None:
    from agents.analysis.earlier_rows import exclusive_outcome

    goal_out_of_bounds = exclusive_outcome({"collision": False, "out_of_bounds": True, "success": True})
    assert (goal_out_of_bounds["success"], goal_out_of_bounds["out_of_bounds"]) == (False, True)
    crash_out_of_bounds = exclusive_outcome({"collision": True, "out_of_bounds": True, "success": False})
    assert (crash_out_of_bounds["collision"], crash_out_of_bounds["out_of_bounds"]) == (True, False)


def test_an_episode_key_reads_typed_rows_and_text_alike() -> None:
    typed = {"agent": "bee", "factor": "clean", "level": 0.5, "seed": 7}
    text = {"agent": "bee", "factor": "clean", "level": "0.5", "seed": "7"}
    assert episode_key(typed) == episode_key(text) == ("bee", "clean", 0.5, 7)


@pytest.mark.parametrize(
    ("level", "seed", "message"),
    [
        (None, 7, "an episode's level is a number, got None"),
        (0.5, 7.0, "an episode's seed is an integer, got 7.0"),
        (0.5, None, "an episode's seed is an integer, got None"),
    ],
)
def test_an_episode_key_refuses_a_level_or_seed_that_is_not_a_number(
    level: object, seed: object, message: str
) -> None:
    row = {"agent": "bee", "factor": "clean", "level": level, "seed": seed}
    with pytest.raises(ValueError, match=f"^{message}$"):
        episode_key(row)
