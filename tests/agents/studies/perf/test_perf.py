"""Smoke tests of the benchmarks (agents.studies.perf): they run on tiny sizes and write their files; no timed asserts."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest

from agents.cli import build_parser
from agents.common import tables
from agents.evaluation import provenance as machine
from agents.studies.perf import depth_loops, depth_yield, env_speed_report, estimator_speed_report, flight
from estimator import CameraIntrinsics
from estimator.geometry import euler_zyx_to_rotation


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
        loop_frames=2,
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
    assert "speedup_vs_loop_floats" in read_header(tmp_path / "estimator_performance_depth_stage.csv")
    report = (tmp_path / "estimator_performance.md").read_text()
    assert "flownav bench estimator" in report and "## Targets" in report
    assert f"OpenGL renderer: {machine.gl_renderer()}" in report


def test_env_benchmark_writes_table_csv_and_plot(tmp_path) -> None:
    paths = env_speed_report.run_env_benchmark(
        resolutions=((64, 48),), steps=3, repeats=1, out_dir=tmp_path, progress=False, fast_thresholds=(30,)
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
    assert [row["config"] for row in rows] == ["FlowNav-v0 (default)", "64×48", "FAST 30"]
    assert [row["fast_threshold"] for row in rows] == ["10", "10", "30"]
    assert all(float(row["ratio_floor_bare"]) > 0 for row in rows)
    report = (tmp_path / "env_performance.md").read_text()
    assert "gym-pybullet-drones" in report and "## FAST threshold" in report
    assert "The floor (bare loop + grayscale + FAST + one LK pass" in report
    assert "--fast-thresholds 30" in report
    software = machine.is_software_renderer(machine.gl_renderer())
    assert ("software OpenGL" in report) == software and ("hardware OpenGL" in report) != software


def test_gl_renderer_names_the_renderer_the_env_draws_with() -> None:
    renderer = machine.gl_renderer()
    assert renderer and not renderer.startswith("unknown"), renderer
    assert renderer in machine.machine_summary()
    assert machine.is_software_renderer("llvmpipe (LLVM 15.0.7, 256 bits)")
    assert not machine.is_software_renderer("NVIDIA H100 80GB HBM3/PCIe/SSE2")


@pytest.mark.parametrize("loop", [depth_loops.depth_loop_floats, depth_loops.depth_loop_numpy])
def test_depth_loops_match_the_vectorised_stage(loop) -> None:
    # The speed-up is only meaningful if the loops compute what the kernel computes.
    rng = np.random.default_rng(0)
    intrinsics = CameraIntrinsics.from_fov(160, 120, 60.0)
    depth = rng.uniform(1.0, 8.0, 200)
    points = rng.uniform([0, 0], [160, 120], (200, 2))
    rotation = euler_zyx_to_rotation(0.01, -0.02, 0.015)
    translation = np.array([0.02, -0.01, -0.1])
    rays = np.column_stack([intrinsics.normalize(points), np.ones(200)]) * depth[:, None]
    moved = rays @ rotation.T + translation
    next_points = intrinsics.denormalize(moved[:, :2] / moved[:, 2:])
    next_points += rng.normal(0, 0.3, next_points.shape)  # some points fail the epipolar check
    arguments = (points, next_points, rotation, translation, intrinsics, 1.0, 1.0)
    expected_depth, expected_valid = depth_loops.depth_vectorised(*arguments)
    got_depth, got_valid = loop(*arguments)
    np.testing.assert_allclose(got_depth, expected_depth, rtol=1e-9)
    np.testing.assert_array_equal(got_valid, expected_valid)
    assert 0 < expected_valid.sum() < 200


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


def test_training_benchmark_times_each_worker_count_and_runs_side_by_side(tmp_path) -> None:
    from agents.studies.perf.training_speed import run_training_benchmark
    from agents.training.train_config import PPOParams, TrainConfig

    config = TrainConfig(
        name="tiny",
        env_id="FlowNavSingle-v0",
        env={"camera_width": 64, "camera_height": 48},
        n_envs=2,
        ppo=PPOParams(n_steps=32, batch_size=32, n_epochs=1, net_arch=[8]),
    )
    md, csv_path = run_training_benchmark(
        config,
        tmp_path / "tiny.yaml",
        (1, 2),
        rollouts=1,
        repeats=1,
        out_dir=tmp_path,
        progress=False,
        side_by_side=2,
    )
    rows = list(csv.DictReader(csv_path.open()))
    assert [(int(r["n_envs"]), int(r["runs_side_by_side"])) for r in rows] == [(1, 1), (2, 1), (2, 2)]
    assert [r["env_workers"] for r in rows] == ["in process", "one subprocess per env", "in process"]
    assert [int(r["rollout_steps"]) for r in rows] == [32, 64, 64]
    assert all(float(r["steps_per_s_median"]) > 0 and float(r["collect_ms_per_step"]) > 0 for r in rows)
    # The machine's rate of two runs is the sum of theirs: at least the slower run's twice. Both are
    # rounded to 0.1 step/s, so after rounding the doubled one may be up to 0.15 above.
    side = rows[2]
    assert float(side["steps_per_s_median"]) >= 2 * float(side["per_run_steps_per_s_median"]) - 0.15 - 1e-6
    text = md.read_text()
    assert "flownav bench train" in text and "--side-by-side 2" in text
    assert "2 runs side by side train" in text
    with pytest.raises(ValueError, match=r"--rollouts, --repeats and every --n-envs must be >= 1"):
        run_training_benchmark(config, tmp_path / "tiny.yaml", (0,), 1, 1, tmp_path)
    with pytest.raises(ValueError, match=r"--side-by-side must be 0 \(off\) or >= 2 runs, got 1"):
        run_training_benchmark(config, tmp_path / "tiny.yaml", (1,), 1, 1, tmp_path, side_by_side=1)


def test_depth_yield_report_compares_each_variant_in_scene(tmp_path) -> None:
    report, figure = depth_yield.run_depth_yield(
        (1, 3), (7,), ("min_parallax_px=0.5",), 1, 6, tmp_path / "absent", tmp_path, progress=False
    )
    text = report.read_text()
    assert figure.stat().st_size > 0
    for variant in ("default", "baseline_frames=3", "fast_threshold=7", "min_parallax_px=0.5"):
        assert f"| {variant} | 6 |" in text  # one summary row per variant, all steps flown
    assert "was not found" in text  # the real-image section says why it is missing
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
        depth_yield.run_depth_yield(frames, (), settings, flights, 5, tmp_path, tmp_path, progress=False)
