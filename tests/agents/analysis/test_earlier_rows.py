"""Earlier episodes CSVs read as today's rows: their headers, a row given today's columns, one outcome each."""

from __future__ import annotations

from pathlib import Path

from agents.analysis.earlier_rows import ADDED_FIELDS, earlier_headers, upgrade_row
from agents.analysis.records import CSV_FIELDS, EARLIER_CSV_FIELDS, RECORD_FIELDS, read_records


def test_each_earlier_header_is_todays_without_the_columns_added_since() -> None:
    headers = earlier_headers(CSV_FIELDS)
    assert headers == EARLIER_CSV_FIELDS and len(headers) == len(ADDED_FIELDS)
    for since, header in enumerate(headers):
        assert [name for name in CSV_FIELDS if name not in header] == list(ADDED_FIELDS[since:])
    assert CSV_FIELDS[-1 - len(ADDED_FIELDS) : -1] == list(ADDED_FIELDS)  # added last, oldest first


def test_an_earlier_row_gets_todays_columns_with_none_for_those_it_predates() -> None:
    raw = {name: f"text of {name}" for name in EARLIER_CSV_FIELDS[1]}
    upgraded = upgrade_row(raw, RECORD_FIELDS)
    assert list(upgraded) == RECORD_FIELDS  # today's columns, in the record's order, the checksum aside
    assert upgraded["suite_version"] is None and upgraded["max_abs_lateral_m"] is None
    assert upgraded["mean_depth_outlier_share"] == "text of mean_depth_outlier_share"
    assert upgrade_row({**raw, "unknown": "x"}, RECORD_FIELDS) == upgraded  # no column beyond today's


def test_a_committed_file_from_before_the_outlier_share_reads_with_those_columns_unknown() -> None:
    path = Path(__file__).resolve().parents[3] / "results" / "leaderboard_episodes.csv"
    header = path.read_text().split("\n", 1)[0].strip().split(",")
    rows = read_records(path)
    assert rows and header == EARLIER_CSV_FIELDS[0]
    assert all(row[name] is None for row in rows[:50] for name in ADDED_FIELDS)
