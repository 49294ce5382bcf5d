"""``estimator_performance.md`` and its figure: the thesis's Table 3 and Figs. 39-40 from the benchmark's rows.
The prose is ``templates/estimator_performance.md.j2``; :func:`estimator_report_values` computes what it states."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from agents.common.jinja_reports import render
from agents.common.tables import write_csv
from agents.studies.perf.estimator_speed import (
    DEFAULT_THRESHOLD,
    MAX_LEVEL,
    TARGET_DEPTH_SPEEDUP,
    TARGET_RATIO_BARE,
    WIN_SIZE,
    run_estimator_table,
)
from agents.studies.perf.flight import record_flight
from agents.studies.perf.report_kit import PACKAGE, RunFacts, rounded, saved_figure, table, write_report
from estimator import CameraIntrinsics, FlowDepthEstimator

Row = dict[str, Any]
# The verdicts judge the rows with at least this many points per frame: at a handful of points every pipeline is
# dominated by fixed per-call costs.
WORKING_POINTS = 100
# The default estimator's settings the report states (read from an instance: :func:`estimator_defaults`).
STATED_SETTINGS = (
    "method",
    "win_size",
    "max_level",
    "max_lk_error",
    "forward_backward",
    "fb_max_error_px",
    "fb_max_level",
    "normalize_brightness",
    "min_parallax_px",
    "max_epipolar_error_px",
)
_FLOAT_SETTINGS = ("max_lk_error", "fb_max_error_px", "min_parallax_px", "max_epipolar_error_px")


def run_estimator_benchmark(
    frames: int = 40,
    thresholds: Sequence[int] = (50, 40, 30, 20, 15, 10, 5, 3, 1),
    repeats: int = 3,
    width: int = 640,
    height: int = 480,
    layout: str = "three",
    seed: int = 0,
    loop_frames: int = 10,
    out_dir: str | Path = "results",
    progress: bool = True,
) -> list[Path]:
    """Record the flight, run :func:`run_estimator_table` and write the Markdown report, CSV and plot.

    Args:
        frames: frame pairs of the flight.
        thresholds: FAST thresholds to sweep.
        repeats: timed passes per configuration.
        width, height: camera resolution (thesis: 640×480).
        layout, seed: the flight's scene.
        loop_frames: frame pairs for the depth-loop comparison.
        out_dir: output folder (created).
        progress: show progress bars.

    Returns:
        Paths of ``estimator_performance.md``, ``.csv``, ``_depth_stage.csv`` and ``.png``.

    Raises:
        ValueError: bad counts, or the flight ends before ``frames`` pairs.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    command = (
        f"flownav bench estimator --frames {frames} --repeats {repeats} "
        f"--thresholds {','.join(map(str, thresholds))} --width {width} --height {height} "
        f"--layout {layout} --seed {seed} --loop-frames {loop_frames} --out {out_dir}"
    )
    started = time.perf_counter()
    with record_flight(frames, width, height, layout, seed) as flight:
        rows, depth_rows = run_estimator_table(flight, thresholds, repeats, loop_frames, progress)
        description = flight.description
    run = RunFacts.of_this_run(command, started)
    stem = out_dir / "estimator_performance"
    paths = [stem.with_suffix(".md"), stem.with_suffix(".csv"), out_dir / f"{stem.name}_depth_stage.csv"]
    paths.append(stem.with_suffix(".png"))
    write_csv(paths[1], rounded(rows))
    write_csv(paths[2], rounded(depth_rows))
    plot_estimator_performance(rows, paths[3])
    values = estimator_report_values(
        rows, depth_rows, description, repeats, loop_frames, estimator_defaults(), run
    )
    write_report(paths[0], "estimator_performance.md.j2", values)
    return paths


def plot_estimator_performance(rows: list[Row], path: Path) -> None:
    """Points (left) and ms per stage (right) against the FAST threshold: the thesis's Figs. 39–40."""
    thresholds = [row["fast_threshold"] for row in rows]
    with saved_figure(path, (11, 4.2)) as figure:
        points_axis, time_axis = figure.subplots(1, 2)
        points_axis.plot(thresholds, [row["points_found"] for row in rows], "o-", label="found (FAST)")
        points_axis.plot(thresholds, [row["points_used"] for row in rows], "s-", label="used (valid depth)")
        points_axis.set_ylabel("points per frame")
        points_axis.set_title("Points vs FAST threshold (cf. thesis Fig. 39)")
        for key, label, style in (
            ("ms_fast", "FAST", "o-"),
            ("ms_flow", "flow (LK, both ways)", "s-"),
            ("ms_depth", "depth", "^-"),
            ("ms_total", "estimator total (FB on)", "D-"),
            ("ms_total_fb_off", "estimator total (FB off)", "v-"),
            ("ms_bare_fast_lk", "bare FAST + LK", "k--"),
        ):
            time_axis.plot(thresholds, [max(row[key], 1e-4) for row in rows], style, label=label)
        time_axis.set_ylabel("ms per frame (median)")
        time_axis.set_title("Time per stage vs FAST threshold (cf. thesis Fig. 40)")
        for axis in (points_axis, time_axis):
            axis.set_yscale("log")
            axis.set_xlabel("FAST threshold")
            axis.invert_xaxis()
            axis.grid(True, which="both", alpha=0.3)
        points_axis.legend()
        time_axis.legend(fontsize=8)


def estimator_defaults() -> dict[str, Any]:
    """The settings of a default ``FlowDepthEstimator`` that the report states.

    Read from a default instance rather than written out, so the report cannot drift from the estimator.

    Returns:
        The attributes named in :data:`STATED_SETTINGS`, by name.
    """
    defaults = FlowDepthEstimator(CameraIntrinsics.from_fov(64, 48, 60.0))
    return {name: getattr(defaults, name) for name in STATED_SETTINGS}


def estimator_report_values(
    rows: list[Row],
    depth_rows: list[Row],
    flight: Mapping[str, Any],
    repeats: int,
    loop_frames: int,
    defaults: Mapping[str, Any],
    run: RunFacts,
) -> dict[str, Any]:
    """Every figure, table and verdict of ``templates/estimator_performance.md.j2``, from
    :func:`run_estimator_table`'s rows (Table 3 and the depth stage), the flight's description
    (``Flight.description``), the benchmark's repeats and loop frames, the estimator's default settings
    (:func:`estimator_defaults`) and the run's facts."""
    return {
        "run": run,
        "repeats": str(repeats),
        "loop_frames": str(loop_frames),
        **_flight_values(flight),
        **_settings_values(defaults),
        "bare_win_size": str(WIN_SIZE),
        "bare_max_level": str(MAX_LEVEL),
        "equal_counts": str(all(row["equal_counts"] for row in rows)),
        "stage_table": _stage_table(rows),
        "depth_table": _depth_table(depth_rows),
        "max_difference": f"{max(row['max_relative_depth_difference'] for row in depth_rows):.1e}",
        "agreement_pct": f"{100 * min(row['valid_mask_agreement'] for row in depth_rows):.2f}",
        **_working_range_values(rows),
        **_target_values(rows, depth_rows),
        **_speedup_growth_values(depth_rows),
    }


def _flight_values(flight: Mapping[str, Any]) -> dict[str, str]:
    return {
        "layout": str(flight["layout"]),
        "seed": str(flight["seed"]),
        "frames": str(flight["frames"]),
        "width": str(flight["width"]),
        "height": str(flight["height"]),
        "fov_deg": f"{flight['fov_deg']:.0f}",
        "forward_speed": str(flight["forward_speed"]),
        "frame_rate": f"{flight['frame_rate']:.0f}",
        "metres_per_frame": f"{flight['forward_speed'] / flight['frame_rate']:.2f}",
    }


def _settings_values(defaults: Mapping[str, Any]) -> dict[str, str | bool]:
    values: dict[str, str | bool] = {name: f"{defaults[name]:g}" for name in _FLOAT_SETTINGS}
    values.update({name: str(defaults[name]) for name in STATED_SETTINGS if name not in _FLOAT_SETTINGS})
    values["fb_one_level"] = defaults["fb_max_level"] == 0
    return values


def _ms(value: float) -> str:
    return f"{value:.3f}" if value < 1 else f"{value:.2f}"


def _stage_table(rows: list[Row]) -> str:
    """Table 3: points and time per stage for each FAST threshold."""
    times = ("prepare", "fast", "flow", "depth", "total", "bare_fast_lk")
    cells = [row | {f"{key}_ms": _ms(row[f"ms_{key}"]) for key in times} for row in rows]
    columns = {
        "FAST thr.": "{fast_threshold}",
        "points found": "{points_found:.0f}",
        "points used": "{points_used:.0f}",
        "prepare ms": "{prepare_ms}",
        "FAST ms": "{fast_ms}",
        "flow ms": "{flow_ms}",
        "depth ms": "{depth_ms}",
        "total ms": "{total_ms}",
        "FPS": "{fps:.0f}",
        "bare FAST+LK ms": "{bare_fast_lk_ms}",
        "ratio FB on": "{ratio_fb_on:.2f}",
        "ratio FB off": "{ratio_fb_off:.2f}",
        "ratio FB full search": "{ratio_fb_full:.2f}",
        "depth err. %": "{depth_error_median_pct:.1f}",
    }
    return table(cells, columns)


def _depth_table(depth_rows: list[Row]) -> str:
    """The depth stage against the two per-point loops, per FAST threshold."""
    times = ("vectorised", "loop_floats", "loop_numpy")
    cells = [row | {f"{key}_ms": _ms(row[f"ms_{key}"]) for key in times} for row in depth_rows]
    columns = [
        ("FAST thr.", "{fast_threshold}"),
        ("points/frame", "{points_per_frame:.0f}"),
        ("vectorised ms", "{vectorised_ms}"),
        ("loop (floats) ms", "{loop_floats_ms}"),
        ("speed-up", "{speedup_vs_loop_floats:.1f}×"),
        ("loop (numpy/pt) ms", "{loop_numpy_ms}"),
        ("speed-up", "{speedup_vs_loop_numpy:.1f}×"),
        (
            "µs/pt vec / floats / numpy",
            "{us_per_point_vectorised:.3f} / {us_per_point_loop_floats:.2f} / {us_per_point_loop_numpy:.1f}",
        ),
    ]
    return table(cells, columns)


def _working(table: list[Row], count_key: str) -> list[Row]:
    """The rows in the working range of point counts, or all rows where none reaches it."""
    return [row for row in table if row[count_key] >= WORKING_POINTS] or table


def _working_range_values(rows: list[Row]) -> dict[str, str | bool]:
    """The default threshold's point count and the thresholds the verdicts' ranges run over."""
    default_row = next((row for row in rows if row["fast_threshold"] == DEFAULT_THRESHOLD), None)
    working = [row for row in rows if row["points_found"] >= WORKING_POINTS]
    values: dict[str, str | bool] = {
        "default_threshold": str(DEFAULT_THRESHOLD),
        "default_swept": default_row is not None,
        "working_points": str(WORKING_POINTS),
        "any_working": bool(working),
    }
    if default_row is not None:
        values["default_points"] = f"{default_row['points_found']:.0f}"
    if working:
        values["working_thresholds"] = ", ".join(str(row["fast_threshold"]) for row in working)
    return values


def _verdict(table: list[Row], count_key: str, key: str, ok: Callable[[float], bool]) -> str:
    """One target's verdict (``templates/target_verdict.md.j2``): at the default threshold, and over the working
    range of point counts, where fixed per-call costs no longer dominate."""
    values = [row[key] for row in _working(table, count_key)]
    at_default = next((row[key] for row in table if row["fast_threshold"] == DEFAULT_THRESHOLD), None)
    fields: dict[str, str | bool] = {
        "swept": at_default is not None,
        "low": f"{min(values):.2f}",
        "high": f"{max(values):.2f}",
        "met_rows": str(sum(bool(ok(value)) for value in values)),
        "rows": str(len(values)),
    }
    if at_default is not None:
        fields.update(at_default=f"{at_default:.2f}", met=bool(ok(at_default)))
    # The verdict sits inside a line of the report: the template file's final newline is not part of it.
    return render(PACKAGE, "target_verdict.md.j2", fields, every_value_used=True).removesuffix("\n")


def _target_values(rows: list[Row], depth_rows: list[Row]) -> dict[str, str]:
    def fast(value: float) -> bool:
        return value <= TARGET_RATIO_BARE

    def faster(value: float) -> bool:
        return value >= TARGET_DEPTH_SPEEDUP

    return {
        "target_ratio": f"{TARGET_RATIO_BARE:.1f}",
        "verdict_fb_on": _verdict(rows, "points_found", "ratio_fb_on", fast),
        "verdict_fb_off": _verdict(rows, "points_found", "ratio_fb_off", fast),
        "verdict_fb_full": _verdict(rows, "points_found", "ratio_fb_full", fast),
        "flow_full_vs_lk": f"{_flow_full_vs_lk(rows):.1f}",
        "target_speedup": f"{TARGET_DEPTH_SPEEDUP:.0f}",
        "verdict_loop_numpy": _verdict(depth_rows, "points_per_frame", "speedup_vs_loop_numpy", faster),
        "verdict_loop_floats": _verdict(depth_rows, "points_per_frame", "speedup_vs_loop_floats", faster),
    }


def _flow_full_vs_lk(rows: list[Row]) -> float:
    """The flow stage with the full backward search (the estimator before the throughput work) over the bare baseline's
    LK, median over the working range.

    Neither is timed alone: the full search's flow stage is the FB-on flow stage plus what the full search
    added to the frame, and the baseline's LK is its frame less FAST (the same detector call as the
    estimator's FAST stage).
    """
    ratios = [
        (row["ms_flow"] + row["ms_total_fb_full"] - row["ms_total"])
        / max(row["ms_bare_fast_lk"] - row["ms_fast"], 1e-9)
        for row in _working(rows, "points_found")
    ]
    return statistics.median(ratios)


def _speedup_growth_values(depth_rows: list[Row]) -> dict[str, str | bool]:
    """Whether the depth stage's speed-up grows with the point count, and its fixed cost where it does: its
    time at the fewest points, where the per-point work is negligible."""
    fewest = min(depth_rows, key=lambda row: row["points_per_frame"])
    most = max(depth_rows, key=lambda row: row["points_per_frame"])
    grows = all(most[key] > fewest[key] for key in ("speedup_vs_loop_floats", "speedup_vs_loop_numpy"))
    values: dict[str, str | bool] = {"speedup_grows": bool(grows)}
    if grows:
        values["fixed_ms"] = f"{fewest['ms_vectorised']:.2f}"
        values["fewest_points"] = f"{fewest['points_per_frame']:.0f}"
    return values
