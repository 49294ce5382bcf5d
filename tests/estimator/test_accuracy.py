"""Tests of estimator.accuracy: the ICL-NUIM-style sequence evaluation and its table."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from helpers import TESTDATA

from estimator import CameraIntrinsics
from estimator.accuracy import (
    evaluate_sequence,
    evaluate_stream,
    format_error_table,
    read_trajectory_log,
    relative_depth_error,
    relative_motion,
)

ICL = TESTDATA / "icl_nuim_livingroom1"
ICL_INTRINSICS = CameraIntrinsics(fx=525.0, fy=525.0, cx=319.5, cy=239.5, width=640, height=480)


@pytest.fixture()
def icl_copy(tmp_path: Path) -> Path:
    """A writable copy of the first three ICL-NUIM frames (to break it in tests)."""
    if not ICL.is_dir():
        pytest.skip(f"third-party test data not found at {ICL}")
    sequence = tmp_path / "sequence"
    for folder, suffix in (("color", "jpg"), ("depth", "png")):
        (sequence / folder).mkdir(parents=True)
        for index in range(3):
            shutil.copy(ICL / folder / f"{index:05d}.{suffix}", sequence / folder / f"{index:05d}.{suffix}")
    shutil.copy(ICL / "trajectory.log", sequence / "trajectory.log")
    return sequence


def test_evaluate_sequence_rows(icl_copy):
    rows = evaluate_sequence(icl_copy, ICL_INTRINSICS, max_gap=2)
    assert [row["pair"] for row in rows] == [(0, 1), (0, 2), (1, 2)]
    for row in rows:
        assert row["valid"] >= 50
        assert row["tracked"] >= row["valid"] >= row["evaluated"]
        assert row["median_rel_error"] <= 0.03
        assert row["within_10pct"] >= 0.8
        assert 0.0 < row["median_epe_px"] <= 1.0
    # The table lists every pair plus a median line.
    table = format_error_table(rows)
    lines = table.splitlines()
    assert lines[0].split()[:3] == ["pair", "tracked", "valid"]
    assert [line.split()[0] for line in lines[2:]] == ["0->1", "0->2", "1->2", "median"]


def test_max_gap_limits_the_pairs(icl_copy):
    rows = evaluate_sequence(icl_copy, ICL_INTRINSICS, method="thesis", max_gap=1)
    assert [row["pair"] for row in rows] == [(0, 1), (1, 2)]


def test_relative_motion_matches_the_documented_convention():
    if not ICL.is_dir():
        pytest.skip(f"third-party test data not found at {ICL}")
    poses = read_trajectory_log(ICL / "trajectory.log")
    rotation, translation = relative_motion(poses[0], poses[4])
    transform = np.linalg.inv(poses[4]) @ poses[0]
    np.testing.assert_allclose(rotation, transform[:3, :3], atol=1e-9)
    np.testing.assert_allclose(translation, transform[:3, 3])
    # README: over frames 0->4 the camera moves about 10 cm and turns about 3 degrees.
    angle = np.degrees(np.arccos((np.trace(rotation) - 1) / 2))
    assert 0.05 < np.linalg.norm(translation) < 0.15
    assert 2.0 < angle < 4.5


def test_format_error_table_shows_missing_values_as_dashes():
    row = {
        "pair": (3, 4),
        "points": 0,
        "tracked": 0,
        "valid": 0,
        "evaluated": 0,
        "median_rel_error": float("nan"),
        "within_10pct": 0.0,
        "median_epe_px": float("nan"),
        "time_ms": 1.0,
    }
    table = format_error_table([row])
    assert "3->4" in table and "-" in table.splitlines()[2]
    assert format_error_table([]).splitlines()[0].startswith("pair")


@pytest.mark.parametrize(
    ("breakage", "message"),
    [
        (lambda sequence: shutil.rmtree(sequence / "color"), r"color folder not found: .*color"),
        (
            lambda sequence: (sequence / "trajectory.log").unlink(),
            r"trajectory log not found: .*trajectory.log",
        ),
        (lambda sequence: (sequence / "depth" / "00001.png").unlink(), r"depth image not found: .*00001.png"),
        (
            lambda sequence: [path.unlink() for path in (sequence / "color").iterdir()],
            r"no .jpg or .png frames in .*color",
        ),
    ],
)
def test_missing_files_raise_file_not_found_with_the_path(icl_copy, breakage, message):
    breakage(icl_copy)
    with pytest.raises(FileNotFoundError, match=message):
        evaluate_sequence(icl_copy, ICL_INTRINSICS)


def test_missing_folder_raises_file_not_found(tmp_path):
    with pytest.raises(FileNotFoundError, match=r"sequence folder not found: .*nowhere"):
        evaluate_sequence(tmp_path / "nowhere", ICL_INTRINSICS)


def test_bad_max_gap_and_malformed_log(icl_copy):
    with pytest.raises(ValueError, match=r"max_gap must be an integer >= 1, got 0"):
        evaluate_sequence(icl_copy, ICL_INTRINSICS, max_gap=0)
    (icl_copy / "trajectory.log").write_text("0 0 1\n1 0 0 0\n")
    with pytest.raises(ValueError, match=r"expected blocks of 5 lines \(header \+ 4x4 pose\), got 2 lines"):
        evaluate_sequence(icl_copy, ICL_INTRINSICS)


def test_short_trajectory_is_rejected(icl_copy):
    lines = (icl_copy / "trajectory.log").read_text().splitlines()
    (icl_copy / "trajectory.log").write_text("\n".join(lines[:10]) + "\n")
    with pytest.raises(ValueError, match=r"has 2 poses for 3 frames"):
        evaluate_sequence(icl_copy, ICL_INTRINSICS)


def test_intrinsics_must_match_the_images(icl_copy):
    wrong = CameraIntrinsics.from_fov(320, 240, 60.0)
    with pytest.raises(ValueError, match=r"must be 320x240 \(width x height\)"):
        evaluate_sequence(icl_copy, wrong, max_gap=1)


def test_cli_eval_estimator_prints_the_table(icl_copy, capsys):
    from agents.cli import main

    assert main(["eval-estimator", "--sequence", str(icl_copy), "--max-gap", "1"]) == 0
    output = capsys.readouterr().out
    assert "median rel err" in output and "0->1" in output and "1->2" in output
    assert main(["eval-estimator", "--sequence", str(icl_copy / "missing")]) == 2
    assert "sequence folder not found" in capsys.readouterr().err


def test_relative_depth_error_is_relative_and_nan_where_nothing_compares():
    errors = relative_depth_error(
        np.array([1.1, 4.0, 2.0, 1.0, 1.0, np.inf]), np.array([1.0, 5.0, np.nan, 2.0, 0.0, 1.0])
    )
    np.testing.assert_allclose(errors[[0, 1, 3]], [0.1, 0.2, 0.5])
    assert np.all(np.isnan(errors[[2, 4, 5]]))  # missing truth, zero truth, infinite estimate
    assert relative_depth_error(np.zeros((2, 3)), np.ones((2, 3))).shape == (2, 3)


def test_evaluate_stream_feeds_frames_in_order_and_reports_the_baselines(icl_copy):
    single = evaluate_stream(icl_copy, ICL_INTRINSICS)
    assert [row["pair"] for row in single] == [(0, 1), (1, 2)]
    assert all(row["baseline_frames"] == 1.0 and row["valid"] >= 50 for row in single)
    multi = evaluate_stream(icl_copy, ICL_INTRINSICS, baseline_frames=2)
    assert multi[0]["valid"] == single[0]["valid"]  # the first pair has no older view to range from
    assert 1.0 < multi[1]["baseline_frames"] <= 2.0 and multi[1]["valid"] > single[1]["valid"]
    assert multi[1]["within_10pct"] > 0.9
    assert [row["pair"] for row in evaluate_stream(icl_copy, ICL_INTRINSICS, step=2)] == [(0, 2)]


@pytest.mark.parametrize("step", [0, -1, 1.5, True])
def test_evaluate_stream_rejects_a_bad_step(icl_copy, step):
    with pytest.raises(ValueError, match=r"step must be an integer >= 1, got"):
        evaluate_stream(icl_copy, ICL_INTRINSICS, step=step)
