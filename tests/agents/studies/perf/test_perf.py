"""Smoke tests of the benchmarks (agents.studies.perf): they run on tiny sizes and write their files; no timed asserts."""

from __future__ import annotations

import csv
import math

import pytest

from agents.cli import build_parser
from agents.common import tables
from agents.evaluation import provenance as machine
from agents.studies.perf import depth_yield, env_speed_report, estimator_speed_report, flight


def read_header(path) -> list[str]:
    with path.open() as handle:
        return next(csv.reader(handle))


def test_estimator_benchmark_writes_table_csv_and_plot(tmp_path) -> None:
    paths = estimator_speed_report.run_estimator_benchmark(
        frames=3,
        thresholds=(30, 20),
        repeats=1,
        width=160,
        height=120,
        out_dir=tmp_path,
        progress=False,
    )
    assert all(path.is_file() and path.stat().st_size > 0 for path in paths)
    header = read_header(tmp_path / "estimator_performance.csv")
    for column in (
        "fast_threshold",
        "points_found",
        "points_used",
        "ms_fast",
        "ms_flow",
        "ms_depth",
        "ms_total",
        "fps",
        "ms_bare_fast_lk",
        "ratio_fb_on",
        "ratio_fb_off",
    ):
        assert column in header
    with (tmp_path / "estimator_performance.csv").open() as handle:
        assert [row["fast_threshold"] for row in csv.DictReader(handle)] == ["30", "20"]
    assert [path.name for path in paths] == [f"estimator_performance.{ext}" for ext in ("md", "csv", "png")]
    report = (tmp_path / "estimator_performance.md").read_text()
    assert "flownav bench estimator" in report and "## Targets" in report
    assert f"OpenGL renderer: {machine.gl_renderer()}" in report


def test_env_benchmark_writes_table_csv_and_plot(tmp_path) -> None:
    paths = env_speed_report.run_env_benchmark(
        resolutions=((64, 48),), steps=3, repeats=1, out_dir=tmp_path, progress=False
    )
    assert all(path.is_file() and path.stat().st_size > 0 for path in paths)
    header = read_header(tmp_path / "env_performance.csv")
    for column in (
        "steps_per_s_env",
        "steps_per_s_bare",
        "ratio_env_bare",
        "ratio_floor_bare",
        "real_time_factor_env",
        "points_tracked_median",
        "points_valid_median",
        "depth_error_median_pct",
        "ms_physics",
        "ms_render",
        "ms_estimator",
        "ms_rest",
    ):
        assert column in header
    with (tmp_path / "env_performance.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    assert [row["config"] for row in rows] == ["FlowNav-v0 (default)", "64×48"]
    assert [row["fast_threshold"] for row in rows] == ["10", "10"]
    assert all(float(row["ratio_floor_bare"]) > 0 for row in rows)
    report = (tmp_path / "env_performance.md").read_text()
    assert "gym-pybullet-drones" in report and "## Where a step's time goes" in report
    assert "The floor (bare loop + grayscale + FAST + one LK pass" in report
    assert "--resolutions 64x48 --steps 3" in report
    software = machine.is_software_renderer(machine.gl_renderer())
    assert ("software OpenGL" in report) == software and ("hardware OpenGL" in report) != software


def test_gl_renderer_names_the_renderer_the_env_draws_with() -> None:
    renderer = machine.gl_renderer()
    assert renderer and not renderer.startswith("unknown"), renderer
    assert renderer in machine.machine_summary()
    assert machine.is_software_renderer("llvmpipe (LLVM 15.0.7, 256 bits)")
    assert not machine.is_software_renderer("NVIDIA H100 80GB HBM3/PCIe/SSE2")


def test_cli_parses_both_targets() -> None:
    parser = build_parser()
    args = parser.parse_args(["bench", "estimator", "--frames", "5", "--thresholds", "20,10"])
    assert args.target == "estimator" and args.frames == 5 and args.thresholds == (20, 10)
    args = parser.parse_args(["bench", "env", "--resolutions", "64x48,160x120"])
    assert args.target == "env" and args.resolutions == ((64, 48), (160, 120))
    with pytest.raises(SystemExit):
        parser.parse_args(["bench", "env", "--resolutions", "64by48"])
    args = parser.parse_args(["bench", "yield", "--frames", "1,4", "--setting", "max_lk_error=8"])
    assert args.target == "yield" and args.frames == (1, 4) and args.setting == ["max_lk_error=8"]


def test_record_flight_rejects_bad_frame_counts() -> None:
    with pytest.raises(ValueError, match="frames"):
        with flight.record_flight(0):
            pass


def test_markdown_table_shape() -> None:
    table = tables.markdown_table(["a", "b"], [[1, math.pi]])
    assert table.splitlines()[0] == "| a | b |" and len(table.splitlines()) == 3


def test_depth_yield_report_compares_each_variant_in_scene(tmp_path) -> None:
    report, figure = depth_yield.run_depth_yield(
        (1, 3), (7,), ("min_parallax_px=0.5",), 1, 6, tmp_path, progress=False
    )
    text = report.read_text()
    assert figure.stat().st_size > 0
    for variant in ("default", "baseline_frames=3", "fast_threshold=7", "min_parallax_px=0.5"):
        assert f"| {variant} | 6 |" in text  # one summary row per variant, all steps flown
    summary, bands = depth_yield.scene_rows({"default": {}}, flights=1, steps=4, progress=False)
    assert summary[0]["valid_per_frame"] > 0 and 0 < summary[0]["within_10pct"] <= 1
    assert len(bands) == len(depth_yield.DEPTH_BANDS) - 1


def test_depth_yield_variants_parse_settings() -> None:
    variants = depth_yield.variant_settings(
        (1, 4), (5,), ("spread_grid=4,4", "max_lk_error=8.5", "fast_threshold=5;baseline_frames=4")
    )
    assert variants == {
        "default": {},
        "baseline_frames=4": {"baseline_frames": 4},
        "fast_threshold=5": {"fast_threshold": 5},
        "spread_grid=4,4": {"spread_grid": (4, 4)},
        "max_lk_error=8.5": {"max_lk_error": 8.5},
        "fast_threshold=5;baseline_frames=4": {"fast_threshold": 5, "baseline_frames": 4},
    }


@pytest.mark.parametrize(
    ("frames", "settings", "flights", "message"),
    [
        ((0,), (), 1, "baseline frames must each be in"),
        ((17,), (), 1, "baseline frames must each be in"),
        ((1,), (), 0, "flights and steps must be >= 1"),
        ((1,), ("max_lk_error",), 1, r"settings must be KEY=VALUE\[;KEY=VALUE...\], got 'max_lk_error'"),
        ((1,), ("no_such_setting=1",), 1, "variant 'no_such_setting=1'"),
        ((1,), ("min_parallax_px=-1",), 1, "min_parallax_px must be"),
    ],
)
def test_depth_yield_rejects_bad_arguments(tmp_path, frames, settings, flights, message) -> None:
    with pytest.raises(ValueError, match=message):
        depth_yield.run_depth_yield(frames, (), settings, flights, 5, tmp_path, progress=False)
