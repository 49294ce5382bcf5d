"""The README's tables: FlowNav's depth metrics, Table 2, Table 3 and the sweeps, and the thesis's Table 2,
Table 3 and variable-test verdicts beside FlowNav's rows (the thesis's numbers come from the rotation config and
:mod:`agents.studies.thesis.reference`), with the figures the Table 2 reading states."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from agents.common.tables import markdown_table
from agents.studies.thesis.reference import TABLE3, THESIS_FOCAL_PX, VARIABLE_TESTS

Row = dict[str, Any]


def num(value: float | None, digits: int = 1) -> str:
    """``value`` to ``digits`` decimals; a dash where it is missing."""
    return "–" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.{digits}f}"


def pct(value: float | None) -> str:
    """A fraction as a percentage to one decimal; a dash where it is missing."""
    return (
        "–" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{100 * value:.1f} %"
    )


def metrics_table(rows: list[Row]) -> str:
    """Depth metric rows (one per run and method)."""
    header = ["run", "method", "median abs. rel. depth error", "within 10 %", "valid points / frame"]
    header += [
        "tracked / frame",
        "median error, capsule points only",
        "capsule points / frame",
        "evaluated points",
    ]
    return markdown_table(
        header,
        [
            [
                row["run"],
                row["method"],
                pct(row["median_rel_error"]),
                pct(row["within_10pct"]),
                num(row["valid_per_frame"]),
                num(row["tracked_per_frame"]),
                pct(row["obstacle_median_rel_error"]),
                num(row["obstacle_valid_per_frame"]),
                row["evaluated"],
            ]
            for row in rows
        ],
    )


def table2_table(rows: list[Row]) -> str:
    """FlowNav's Table 2 in full: residuals with the rotation matrix and with the Euler-angle derotation."""
    header = [
        "case",
        "frame pairs",
        "points detected",
        "points tracked",
        "mean \\|p2 − p2′\\| incl. outliers (px)",
    ]
    header += [
        "excl. outliers (px)",
        "outliers (> 5 px)",
        "Euler-angle derotation (thesis), incl. / excl. (px)",
    ]
    header += ["Euler order (px)", "mean \\|p2 − p1\\| without compensation (px)"]
    return markdown_table(
        header,
        [
            [
                r["case"],
                r["frame_pairs"],
                r["detected"],
                r["tracked"],
                num(r["matrix_mean_px"], 3),
                num(r["matrix_mean_inliers_px"], 3),
                r["matrix_outliers"],
                f"{num(r['euler_mean_px'], 3)} / {num(r['euler_mean_inliers_px'], 3)}",
                num(r.get("euler_order_shift_px", math.nan), 2),
                num(r["uncompensated_mean_px"], 2),
            ]
            for r in rows
        ],
    )


def table3_table(rows: list[Row]) -> str:
    """Per-stage times of the estimator, per method."""
    cells = [[r["method"], r["stage"], f"{r['mean_ms']:.2f}", f"{r['median_ms']:.2f}"] for r in rows]
    return markdown_table(["method", "stage", "mean (ms)", "median (ms)"], cells)


def sweep_table(rows: list[Row]) -> str:
    """One row per variable, value and method of the three-capsule sweeps."""
    header = [
        "variable",
        "value",
        "method",
        "median abs. rel. depth error",
        "within 10 %",
        "valid points / frame",
    ]
    header += ["median error, capsule points only", "frames"]
    return markdown_table(
        header,
        [
            [
                r["variable"],
                f"{r['value']:g}",
                r["method"],
                pct(r["median_rel_error"]),
                pct(r["within_10pct"]),
                num(r["valid_per_frame"]),
                pct(r["obstacle_median_rel_error"]),
                r["frames"],
            ]
            for r in rows
        ],
    )


def _angles(degrees: Sequence[float]) -> str:
    return ", ".join(f"{value:g}" for value in degrees)


def table2_comparison(rows: list[Row]) -> str:
    """The thesis's Table 2 beside FlowNav's, case by case (cases the thesis did not fly marked ours)."""
    header = ["test (Unity rot x, y, z; deg)", "FlowNav pitch, yaw, roll (deg)"]
    header += [
        "mean \\|p2 − p2′\\| incl. outliers, thesis / FlowNav (px)",
        "excl. outliers, thesis / FlowNav (px)",
    ]
    header += ["points incl., thesis / FlowNav per pair", "points excl., thesis / FlowNav per pair"]
    lines = []
    for r in rows:
        thesis, pairs = r.get("thesis"), max(r["frame_pairs"], 1)
        ours_points, ours_inliers = r["tracked"] / pairs, (r["tracked"] - r["matrix_outliers"]) / pairs
        if thesis is None:
            label, t_mean, t_in, t_points, t_inliers = r["case"] + " (ours)", "–", "–", "–", "–"
        else:
            label = f"{thesis['test']} ({_angles(thesis['unity_deg'])})"
            t_mean = num(thesis["mean_px"], 3)
            t_in = "all outliers" if thesis["mean_inliers_px"] is None else num(thesis["mean_inliers_px"], 3)
            t_points, t_inliers = str(thesis["points"]), str(thesis["points_inliers"])
        lines.append(
            [
                label,
                _angles(r["flown_deg"]) if r.get("flown_deg") else "–",
                f"{t_mean} / {num(r['matrix_mean_px'], 3)}",
                f"{t_in} / {num(r['matrix_mean_inliers_px'], 3)}",
                f"{t_points} / {ours_points:.0f}",
                f"{t_inliers} / {ours_inliers:.0f}",
            ]
        )
    return markdown_table(header, lines)


def _span(values: list[float], digits: int = 2) -> str:
    values = [v for v in values if v is not None and not math.isnan(v)]
    if not values:
        return "–"
    low, high = min(values), max(values)
    same = round(low, digits) == round(high, digits)
    return f"{low:.{digits}f}" if same else f"{low:.{digits}f}–{high:.{digits}f}"


def _axes_turned(row: Row) -> int:
    """How many axes the thesis's case turns about."""
    return sum(abs(a) > 0 for a in row["thesis"]["unity_deg"])


def _point_count_gaps(quoted: list[Row]) -> list[str]:
    """The cases where one program keeps less than half the other's points per pair, each as the reading words
    it: ``test 3: 120 against 310``."""
    gaps = []
    for r in quoted:
        ours, theirs = r["tracked"] / max(r["frame_pairs"], 1), r["thesis"]["points"]
        if theirs < 0.5 * ours or ours < 0.5 * theirs:
            gaps.append(f"test {r['thesis']['test']}: {theirs} against {ours:.0f}")
    return gaps


def _mean_spans(cases: list[Row], name: str) -> dict[str, str]:
    """The thesis's and FlowNav's mean errors over ``cases`` as spans: ``<name>_thesis`` and ``<name>_ours``."""
    return {
        f"{name}_thesis": _span([r["thesis"]["mean_px"] for r in cases]),
        f"{name}_ours": _span([r["matrix_mean_px"] for r in cases]),
    }


def _worst_case(quoted: list[Row]) -> dict[str, str]:
    """The thesis's case with the largest mean error, that error in pixels and as a rotation error in degrees."""
    worst = max(quoted, key=lambda r: r["thesis"]["mean_px"])
    return {
        "worst_test": str(worst["thesis"]["test"]),
        "worst_px": f"{worst['thesis']['mean_px']:g}",
        "worst_deg": f"{math.degrees(worst['thesis']['mean_px'] / THESIS_FOCAL_PX):.1f}",
    }


def table2_reading(rows: list[Row]) -> dict[str, str] | None:
    """The figures of the README's reading of Table 2: single- and two-axis cases, thesis and FlowNav, and the
    worst thesis case as a rotation error; None where no case quotes the thesis."""
    quoted = [r for r in rows if r.get("thesis")]
    if not quoted:
        return None
    single = [r for r in quoted if _axes_turned(r) == 1]
    double = [r for r in quoted if _axes_turned(r) >= 2]
    return {
        **_mean_spans(single, "single"),
        "double_tests": ", ".join(str(r["thesis"]["test"]) for r in double),
        **_mean_spans(double, "double"),
        "double_ours_inliers": _span([r["matrix_mean_inliers_px"] for r in double]),
        "order_shift": f"{max((r.get('euler_order_shift_px', 0.0) for r in double), default=0.0):.2f}",
        **_worst_case(quoted),
        "count_outliers": "; ".join(_point_count_gaps(quoted)),
    }


def table3_comparison(timings: list[Row], rows: list[Row], threshold: int) -> str:
    """The thesis's Table 3 rows at our FAST threshold and at our point count, beside ours."""
    ours = {(t["method"], t["stage"]): t["median_ms"] for t in timings}
    by_method = {r["method"]: r for r in rows}
    used = by_method.get("thesis", {}).get("valid_per_frame", math.nan)
    same_threshold = [row for row in TABLE3 if row[1] == threshold]
    nearest = min(TABLE3, key=lambda row: abs(row[8] - used)) if not math.isnan(used) else None
    picked = same_threshold + ([nearest] if nearest and nearest not in same_threshold else [])
    lines = [
        [
            f"thesis, test {test} (i7-4702MQ)",
            th,
            f"{1e3 * fast:.1f}",
            f"{1e3 * flow:.1f}",
            f"{1e3 * depth:.1f}",
            f"{1e3 * total:.0f}",
            f"{found:g}",
            f"{used_t:g}",
            f"{fps:g}",
        ]
        for test, th, _er, fast, flow, depth, total, found, used_t, fps in picked
    ]
    for method in ("thesis", "triangulation"):
        total = ours.get((method, "total"), math.nan)
        row = by_method.get(method, {})
        lines.append(
            [
                f"FlowNav, {method} method (median)",
                threshold,
                *(num(ours.get((method, stage))) for stage in ("fast", "flow", "depth")),
                num(total),
                num(row.get("tracked_per_frame"), 0),
                num(row.get("valid_per_frame"), 0),
                num(1e3 / total if total else math.nan, 0),
            ]
        )
    header = ["run", "FAST threshold", "FAST (ms)", "optical flow (ms)", "depth (ms)", "total (ms)"]
    return markdown_table([*header, "points tracked", "points used", "FPS (estimator only)"], lines)


def verdict_table(sweeps: list[Row], method: str = "thesis") -> str:
    """Per variable test, the thesis's levels and verdict beside FlowNav's rows (one method)."""
    lines = []
    for name, variable, (low, high), levels, verdict in VARIABLE_TESTS:
        rows = sorted(
            (
                r
                for r in sweeps
                if r["variable"] == variable and r["method"] == method and low <= r["value"] <= high
            ),
            key=lambda r: r["value"],
        )
        if not rows:
            continue
        errors = ", ".join(num(100 * r["median_rel_error"]) for r in rows)
        within = f"{num(100 * rows[0]['within_10pct'], 0)} → {num(100 * rows[-1]['within_10pct'], 0)} %"
        points = f"{rows[0]['valid_per_frame']:.0f} → {rows[-1]['valid_per_frame']:.0f}"
        values = ", ".join(f"{r['value']:g}" for r in rows)
        result = f"at {values}: median error {errors} %; within 10 %: {within}; valid points/frame {points}"
        lines.append([name, levels, verdict, result])
    header = ["variable", "levels (thesis)", "thesis's verdict"]
    return markdown_table([*header, "FlowNav's result (`thesis` method, from the rows below)"], lines)
