"""``flownav rule-resolution``: its options reach the study, and bad ones are one line."""

from __future__ import annotations

from pathlib import Path

import pytest

from agents.cli import main


def test_report_only_writes_the_page_from_what_the_folder_holds(tmp_path: Path, capsys) -> None:
    assert main(["rule-resolution", "--out", str(tmp_path), "--search-layouts", "2", "--report-only"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("# The flow rules at finer depth histograms")
    assert (
        "on the same 2 validation layouts per tier from 974,000" in out
        and "- vfh at 3x15-9bins (search)" in out
    )
    assert (tmp_path / "rule_resolution.md").is_file() and not (tmp_path / "episodes.csv").exists()


def test_the_refinement_layouts_reach_the_page(tmp_path: Path, capsys) -> None:
    assert main(["rule-resolution", "--out", str(tmp_path), "--refine-layouts", "3", "--report-only"]) == 0
    out = capsys.readouterr().out
    assert "on 3 fresh validation layouts per tier from 976,000 (`RULE_RESOLUTION_REFINE_SEED_START`)" in out
    assert "- bee_ttc at 3x5-9bins (refinement)" in out


@pytest.mark.parametrize(
    ("option", "value", "message"),
    [
        ("--search-layouts", "0", "search layouts must be an integer in [1, 1000], got 0"),
        ("--refine-layouts", "0", "refinement layouts must be an integer in [1, 1000], got 0"),
        ("--confirm-layouts", "1001", "confirmation layouts must be an integer in [1, 1000], got 1001"),
    ],
)
def test_a_layout_count_out_of_range_is_one_line(
    tmp_path: Path, capsys, option: str, value: str, message: str
) -> None:
    assert main(["rule-resolution", "--out", str(tmp_path), option, value, "--report-only"]) == 2
    assert capsys.readouterr().err.strip() == f"flownav rule-resolution: error: {message}"
