"""The error report of a sweep flown on suite tiers, on synthetic episodes with known answers: rows grouped by
tier, the suite's clean rates as the baseline, cells paired with clean by layout, sideways extents, tolerances
beside an earlier sweep's, the page and the command line."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
from helpers import EPISODE

from agents.analysis.records import append_record
from agents.cli import main
from agents.reports.error_analysis_report import default_baseline, write_error_analysis_from
from agents.studies.error_analysis_tiers import (
    BEST_LEARNED,
    paired_cells,
    rows_by_tier,
    sideways_cells,
    tier_baseline,
    tier_name,
    tolerance_shifts,
)
from flownav_env.tiers import tier_value


def _row(
    agent: str, factor: str, level: float, seed: int, failed: bool, env_id: str = "FlowNav-v1", **extra
) -> dict:
    return {
        "agent": agent,
        "factor": factor,
        "level": level,
        "seed": seed,
        "success": not failed,
        "env_id": env_id,
        **extra,
    }


def test_rows_are_grouped_by_the_tier_their_env_id_names() -> None:
    assert (tier_name("FlowNav-v1"), tier_name("FlowNavHard-v1"), tier_name("FlowNav-v0")) == (
        "clean",
        "hard",
        "clean",
    )
    assert tier_name("FlowNavSingle-v0") == "FlowNavSingle-v0" and tier_name(None) == ""
    rows = [
        _row("bee", "clean", 0.0, 1, False, env) for env in ("FlowNavHard-v1", "FlowNav-v1", "FlowNavHard-v1")
    ]
    assert {tier: len(members) for tier, members in rows_by_tier(rows).items()} == {"hard": 2, "clean": 1}


def test_the_suites_rows_of_the_swept_tier_are_its_clean_cells() -> None:
    suite = [
        _row("bee", "hard", 0.0, 3_000_000, True, "FlowNavHard-v1"),
        _row("bee", "clean", 0.0, 3_000_000, False),
    ]
    (clean,) = tier_baseline(suite, "FlowNavHard-v1")
    assert (clean["factor"], clean["level"], clean["success"]) == ("clean", 0.0, False)


def test_a_cell_is_paired_with_clean_layout_by_layout() -> None:
    seeds = range(3_000_000, 3_000_020)
    rows = [_row("bee", "clean", 0.0, s, s % 10 == 0) for s in seeds]  # 2 of 20 fail
    rows += [_row("bee", "depth_noise", 0.4, s, True) for s in seeds]  # every layout fails
    rows += [_row("bee", "depth_noise", 0.1, s, s % 10 == 0) for s in seeds]  # the same layouts fail
    rows += [_row("bee", "depth_noise", 0.8, 3_000_000, True)]  # one layout: nothing to pair
    cells = {(c.level): c for c in paired_cells(rows)}
    assert set(cells) == {0.4, 0.1}
    assert cells[0.4].difference == pytest.approx(0.9) and cells[0.4].low > 0 and cells[0.4].layouts == 20
    assert (cells[0.1].difference, cells[0.1].low, cells[0.1].high) == (0.0, 0.0, 0.0)


def test_successes_past_the_closed_fields_edge_are_counted_per_cell() -> None:
    edge = float(tier_value("clean", "field_width", "2")) / 2.0
    rows = [
        _row("bee", "clean", 0.0, 1, False, max_abs_lateral_m=edge - 0.5),
        _row("bee", "clean", 0.0, 2, False, max_abs_lateral_m=edge + 0.2),
        _row("bee", "clean", 0.0, 3, True, max_abs_lateral_m=edge + 1.0),  # a failure: not counted
        _row("bee", "depth_noise", 0.4, 1, False, max_abs_lateral_m=float("nan")),  # no record
    ]
    (cell,) = sideways_cells(rows, "clean", "2")
    assert (cell.successes, cell.past_field, cell.widest) == (2, 1, pytest.approx(edge + 0.2))


def _tolerance(
    agent: str, factor: str, levels: list[float], breaking: float | None, clean: float = 0.1
) -> dict:
    return {
        "agent": agent,
        "factor": factor,
        "side": "above",
        "levels": levels,
        "tolerated_level": levels[0],
        "breaking_level": breaking,
        "clean_failure": clean,
    }


def test_breaking_points_are_compared_on_the_levels_both_sweeps_flew() -> None:
    before = [
        _tolerance("bee", "rotation_error", [0.1, 0.3, 1.0], 1.0),
        _tolerance("bee", "depth_noise", [0.1, 0.4], 0.4),
        _tolerance("vfh", "depth_noise", [0.1, 0.4], None),
        _tolerance("ppo_flow@all", "depth_noise", [0.1, 0.4], None, clean=0.05),
    ]
    now = [
        _tolerance("bee", "rotation_error", [0.1, 0.2, 0.3, 1.0], 0.2),  # 0.2 is new: it moves nothing
        _tolerance("bee", "depth_noise", [0.1, 0.4], 0.1),
        _tolerance("vfh", "depth_noise", [0.1, 0.4], 0.4),
        _tolerance("ppo_flow_camera_student_fine_rounds6@all", "depth_noise", [0.1, 0.4], 0.4, clean=0.1),
    ]
    moved = {
        (s.agent, s.factor): (s.before_breaks, s.now_breaks, s.moved) for s in tolerance_shifts(now, before)
    }
    assert moved == {
        (BEST_LEARNED, "depth_noise"): (None, 0.4, "earlier"),
        ("bee", "rotation_error"): (1.0, None, "later"),
        ("bee", "depth_noise"): (0.4, 0.1, "earlier"),
        ("vfh", "depth_noise"): (None, 0.4, "earlier"),
    }


def _write(path: Path, rows: list[dict]) -> None:
    for row in rows:
        append_record(path, dataclasses.replace(EPISODE, **{**row, "collision": not row["success"]}))


def test_the_tiered_page_has_a_section_per_tier_and_the_earlier_sweep_beside_it(tmp_path: Path) -> None:
    seeds = range(3_000_000, 3_000_030)
    clean, hard, suite = tmp_path / "clean.csv", tmp_path / "hard.csv", tmp_path / "suite.csv"
    _write(clean, [_row("bee", "clean", 0.0, s, s % 10 == 0) for s in seeds])
    _write(clean, [_row("bee", "depth_noise", 0.4, s, s % 2 == 0) for s in seeds])
    _write(hard, [_row("bee", "clean", 0.0, s, s % 5 == 0, "FlowNavHard-v1") for s in seeds])
    _write(hard, [_row("bee", "depth_noise", 0.4, s, True, "FlowNavHard-v1") for s in seeds])
    _write(suite, [_row("bee", "clean", 0.0, s, s % 10 == 0) for s in range(3_000_000, 3_000_100)])
    before, before_clean = tmp_path / "v0.csv", tmp_path / "v0_clean.csv"
    _write(
        before,
        [
            _row("bee", f, x, s, f != "clean", "FlowNav-v0")
            for f, x in (("clean", 0.0), ("depth_noise", 0.4))
            for s in range(1_000_000, 1_000_030)
        ],
    )
    _write(
        before_clean, [_row("bee", "clean", 0.0, s, False, "FlowNav-v0") for s in range(1_000_000, 1_000_030)]
    )
    assert default_baseline([clean]).name == "suite_episodes.csv"
    assert default_baseline([before]).name == "leaderboard_episodes.csv"
    write_error_analysis_from(
        [clean, hard], tmp_path / "out", "flownav error-analysis", suite, compare_with=(before, before_clean)
    )
    text = (tmp_path / "out" / "error_analysis.md").read_text()
    assert "## The clean tier (`FlowNav-v1`)" in text and "## The hard tier (`FlowNavHard-v1`)" in text
    assert text.count("**under way**") == 2  # 30 layouts per cell, short of 100
    assert "| depth_noise | 0.4 | 30 | **+0.80** +0." in text  # hard: every layout fails, against 0.2
    assert "| clean failure |  | 0.10 [" in text and "100 episodes |" in text  # the suite's rate on clean
    assert "| bee | depth_noise | above | 0 | 0 | 0.4 | 0.4 | same |" in text
    assert (tmp_path / "out" / "dose_response.png").exists() or "no fit" in text


def test_a_missing_comparison_file_is_named(tmp_path: Path) -> None:
    episodes = tmp_path / "clean.csv"
    _write(episodes, [_row("bee", "clean", 0.0, s, False) for s in range(3_000_000, 3_000_003)])
    with pytest.raises(FileNotFoundError, match=r"--compare-with .*v0\.csv: no such file"):
        write_error_analysis_from(
            [episodes], tmp_path, "c", None, compare_with=(tmp_path / "v0.csv", episodes)
        )
    with pytest.raises(FileNotFoundError, match=r"--episodes .*missing\.csv: no such file"):
        write_error_analysis_from([episodes, tmp_path / "missing.csv"], tmp_path, "c")


def test_the_command_line_takes_an_episodes_file_per_tier(tmp_path: Path, capsys) -> None:
    clean, hard = tmp_path / "clean.csv", tmp_path / "hard.csv"
    _write(clean, [_row("bee", "clean", 0.0, s, s % 3 == 0) for s in range(3_000_000, 3_000_012)])
    _write(clean, [_row("bee", "depth_noise", 0.4, s, True) for s in range(3_000_000, 3_000_012)])
    _write(
        hard,
        [_row("bee", "clean", 0.0, s, s % 2 == 0, "FlowNavHard-v1") for s in range(3_000_000, 3_000_012)],
    )
    out = tmp_path / "out"
    args = [
        "error-analysis",
        "--episodes",
        str(clean),
        "--episodes",
        str(hard),
        "--baseline",
        "",
        "--out",
        str(out),
    ]
    assert main(args) == 0
    text = (out / "error_analysis.md").read_text()
    assert "## The clean tier" in text and "## The hard tier" in text and "(sweep)" in text
