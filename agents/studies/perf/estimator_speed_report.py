"""``estimator_performance.md`` and its figure: the thesis's Table 3 and Figs. 39-40 from the benchmark's rows.
The prose is ``templates/estimator_performance.md.j2``; :func:`estimator_report_values` computes what it states."""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from agents.analysis.perf_rows import FlightDescription
from agents.common.jinja_reports import render
from agents.common.tables import write_csv
from agents.studies.perf.estimator_speed import (
    DEFAULT_THRESHOLD,
    ESTIMATOR_CONFIGS,
    MAX_LEVEL,
    TARGET_RATIO_BARE,
    WIN_SIZE,
    run_estimator_table,
)
from agents.studies.perf.flight import record_flight
from agents.studies.perf.report_kit import (
    PACKAGE,
    RunFacts,
    rounded,
    saved_figure,
    table,
    write_report,
)
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
    out_dir: str | Path = "results",
    progress: bool = True,
) -> list[Path]:
    """Record the flight (``frames`` pairs at ``width``×``height`` in ``layout``, ``seed``), run
    :func:`run_estimator_table` on it and write ``estimator_performance.md``, ``.csv`` and ``.png`` to ``out_dir``
    (created). Returns their paths.

    Raises:
        ValueError: bad counts, or the flight ends before ``frames`` pairs.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    command = (
        f"flownav bench estimator --frames {frames} --repeats {repeats} "
        f"--thresholds {','.join(map(str, thresholds))} --width {width} --height {height} "
        f"--layout {layout} --seed {seed} --out {out_dir}"
    )
    started = time.perf_counter()
    with record_flight(frames, width, height, layout, seed) as flight:
        rows = run_estimator_table(flight, thresholds, repeats, progress)
        description = flight.description
    run = RunFacts.of_this_run(command, started)
    paths = [out_dir / f"estimator_performance.{ext}" for ext in ("md", "csv", "png")]
    write_csv(paths[1], rounded(rows))
    plot_estimator_performance(rows, paths[2])
    values = estimator_report_values(rows, description, repeats, estimator_defaults(), run)
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


def estimator_defaults() -> dict[str, object]:
    """The settings of a default ``FlowDepthEstimator`` that the report states.

    Read from a default instance rather than written out, so the report cannot drift from the estimator.

    Returns:
        The attributes named in :data:`STATED_SETTINGS`, by name.
    """
    defaults = FlowDepthEstimator(CameraIntrinsics.from_fov(64, 48, 60.0))
    return {name: getattr(defaults, name) for name in STATED_SETTINGS}


@dataclass(frozen=True)
class FlightValues:
    """How the flight was made (:class:`~agents.analysis.perf_rows.FlightDescription`), as the report states it,
    and the metres flown per frame."""

    layout: str
    seed: str
    frames: str
    width: str
    height: str
    fov_deg: str
    frame_rate: str
    forward_speed: str
    metres_per_frame: str


@dataclass(frozen=True)
class EstimatorSettingsValues:
    """The estimator's default settings the report states (:data:`STATED_SETTINGS`), and whether its
    forward-backward check runs on one pyramid level."""

    method: str
    win_size: str
    max_level: str
    max_lk_error: str
    forward_backward: str
    fb_max_error_px: str
    fb_max_level: str
    normalize_brightness: str
    min_parallax_px: str
    max_epipolar_error_px: str
    fb_one_level: bool


@dataclass(frozen=True)
class EstimatorTargetValues:
    """The verdicts against the bare-baseline target (:func:`_target_values`): the default threshold's points
    (None where it was not swept) and the working range's thresholds (None where no row reaches it), and each of
    :data:`ESTIMATOR_CONFIGS`' verdict."""

    default_threshold: str
    default_swept: bool
    working_points: str
    any_working: bool
    target_ratio: str
    default_points: str | None
    working_thresholds: str | None
    verdict_fb_on: str
    verdict_fb_off: str


@dataclass(frozen=True)
class EstimatorPerformanceValues(EstimatorTargetValues, EstimatorSettingsValues, FlightValues):
    """Every value ``templates/estimator_performance.md.j2`` words (:func:`estimator_report_values`)."""

    run: RunFacts
    repeats: str
    bare_win_size: str
    bare_max_level: str
    equal_counts: str
    stage_table: str


@dataclass(frozen=True)
class VerdictValues:
    """One configuration's verdict (``templates/target_verdict.md.j2``): its ratio at the default threshold and
    whether it meets the target there (both None where the default was not swept), and its range over the rows."""

    swept: bool
    low: str
    high: str
    met_rows: str
    rows: str
    at_default: str | None
    met: bool | None


def estimator_report_values(
    rows: list[Row],
    flight: FlightDescription,
    repeats: int,
    defaults: Mapping[str, object],
    run: RunFacts,
) -> EstimatorPerformanceValues:
    """Every figure, table and verdict of the report, from :func:`run_estimator_table`'s rows (Table 3), the
    flight's description (``Flight.description``), the benchmark's repeats, the estimator's default settings
    (:func:`estimator_defaults`) and the run's facts."""
    # Each part is handed on whole, by its fields (``vars``: shallow, as the template is given them).
    return EstimatorPerformanceValues(
        **vars(_flight_values(flight)),
        **vars(_settings_values(defaults)),
        **vars(_target_values(rows)),
        run=run,
        repeats=str(repeats),
        bare_win_size=str(WIN_SIZE),
        bare_max_level=str(MAX_LEVEL),
        equal_counts=str(all(row["equal_counts"] for row in rows)),
        stage_table=_stage_table(rows),
    )


def _flight_values(flight: FlightDescription) -> FlightValues:
    stated = {key: str(value) for key, value in flight.items()}
    return FlightValues(
        **stated
        | {
            "fov_deg": f"{flight['fov_deg']:.0f}",
            "frame_rate": f"{flight['frame_rate']:.0f}",
        },
        metres_per_frame=f"{flight['forward_speed'] / flight['frame_rate']:.2f}",
    )


def _settings_values(defaults: Mapping[str, object]) -> EstimatorSettingsValues:
    stated = {name: f"{defaults[name]:g}" for name in _FLOAT_SETTINGS}
    stated.update({name: str(defaults[name]) for name in STATED_SETTINGS if name not in _FLOAT_SETTINGS})
    return EstimatorSettingsValues(**stated, fb_one_level=defaults["fb_max_level"] == 0)


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
        "depth err. %": "{depth_error_median_pct:.1f}",
    }
    return table(cells, columns)


def _target_values(rows: list[Row]) -> EstimatorTargetValues:
    """The verdicts against the bare-baseline target: at the default threshold, and over the rows in the working
    range of point counts (all rows where none reaches it), where fixed per-call costs no longer dominate."""
    default = next((row for row in rows if row["fast_threshold"] == DEFAULT_THRESHOLD), None)
    working = [row for row in rows if row["points_found"] >= WORKING_POINTS]
    verdicts = {
        f"verdict_{name}": _verdict(working or rows, default, f"ratio_{name}") for name in ESTIMATOR_CONFIGS
    }
    return EstimatorTargetValues(
        default_threshold=str(DEFAULT_THRESHOLD),
        default_swept=default is not None,
        working_points=str(WORKING_POINTS),
        any_working=bool(working),
        target_ratio=f"{TARGET_RATIO_BARE:.1f}",
        default_points=None if default is None else f"{default['points_found']:.0f}",
        working_thresholds=", ".join(str(row["fast_threshold"]) for row in working) if working else None,
        **verdicts,
    )


def _verdict(working: list[Row], default: Row | None, key: str) -> str:
    """One configuration's verdict: its ratio at the default threshold and its range over the working rows."""
    ratios = [row[key] for row in working]
    fields = VerdictValues(
        swept=default is not None,
        low=f"{min(ratios):.2f}",
        high=f"{max(ratios):.2f}",
        met_rows=str(sum(bool(ratio <= TARGET_RATIO_BARE) for ratio in ratios)),
        rows=str(len(ratios)),
        at_default=None if default is None else f"{default[key]:.2f}",
        met=None if default is None else bool(default[key] <= TARGET_RATIO_BARE),
    )
    # The verdict sits inside a line of the report: the template file's final newline is not part of it.
    return render(PACKAGE, "target_verdict.md.j2", fields, every_value_used=True).removesuffix("\n")
