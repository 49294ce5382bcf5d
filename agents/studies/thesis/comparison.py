"""The README's comparisons with the thesis: its Table 3 and variable-test verdicts beside FlowNav's rows (the
thesis's numbers come from :mod:`agents.studies.thesis.reference`) and the figures the Table 2 reading states;
``templates/thesis_tables.j2`` words the tables of FlowNav's own rows."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TypedDict

from agents.pages.wording import span
from agents.studies.thesis.metrics import MetricRow
from agents.studies.thesis.reference import TABLE3, THESIS_FOCAL_PX, VARIABLE_TESTS
from agents.studies.thesis.results import SweepRow, Table2Row, ThesisRotationQuote, TimingRow


class Table3Comparison(TypedDict):
    """The thesis's Table 3 rows (at our FAST threshold, and at our point count) and ours per method: median
    stage times (ms), total, frames per second, points tracked and valid per frame (None: not measured)."""

    thesis: Sequence[tuple[float, ...]]
    ours: list[dict[str, float | str | None]]
    threshold: int


class VerdictRows(TypedDict):
    """A variable test of the thesis (its name, levels and verdict) beside FlowNav's rows in its range."""

    name: str
    levels: str
    verdict: str
    rows: list[SweepRow]


def _span(values: list[float]) -> str:
    found = [v for v in values if v is not None and not math.isnan(v)]
    return span(found, 2) if found else "–"


def _axes_turned(quote: ThesisRotationQuote) -> int:
    """How many axes the thesis's case turns about."""
    return sum(abs(a) > 0 for a in quote["unity_deg"])


def _point_count_gaps(quoted: list[tuple[Table2Row, ThesisRotationQuote]]) -> list[str]:
    """The cases where one program keeps less than half the other's points per pair, each as the reading words
    it: ``test 3: 120 against 310``."""
    gaps = []
    for r, thesis in quoted:
        ours, theirs = r["tracked"] / max(r["frame_pairs"], 1), thesis["points"]
        if theirs < 0.5 * ours or ours < 0.5 * theirs:
            gaps.append(f"test {thesis['test']}: {theirs} against {ours:.0f}")
    return gaps


def table2_reading(rows: list[Table2Row]) -> dict[str, str] | None:
    """The figures of the README's reading of Table 2: single- and two-axis cases, thesis and FlowNav, and the
    worst thesis case as a rotation error; None where no case quotes the thesis."""
    # Each case that quotes the thesis, beside its quote.
    quoted = [(r, thesis) for r in rows if (thesis := r.get("thesis"))]
    if not quoted:
        return None
    single = [(r, thesis) for r, thesis in quoted if _axes_turned(thesis) == 1]
    double = [(r, thesis) for r, thesis in quoted if _axes_turned(thesis) >= 2]
    # The thesis's case with the largest mean error: that error in pixels and as a rotation error in degrees.
    _, worst = max(quoted, key=lambda pair: pair[1]["mean_px"])
    return {
        "single_thesis": _span([thesis["mean_px"] for _, thesis in single]),
        "single_ours": _span([r["matrix_mean_px"] for r, _ in single]),
        "double_tests": ", ".join(str(thesis["test"]) for _, thesis in double),
        "double_thesis": _span([thesis["mean_px"] for _, thesis in double]),
        "double_ours": _span([r["matrix_mean_px"] for r, _ in double]),
        "double_ours_inliers": _span([r["matrix_mean_inliers_px"] for r, _ in double]),
        "order_shift": f"{max((r.get('euler_order_shift_px', 0.0) for r, _ in double), default=0.0):.2f}",
        "worst_test": str(worst["test"]),
        "worst_px": f"{worst['mean_px']:g}",
        "worst_deg": f"{math.degrees(worst['mean_px'] / THESIS_FOCAL_PX):.1f}",
        "count_outliers": "; ".join(_point_count_gaps(quoted)),
    }


def table3_comparison(timings: list[TimingRow], rows: list[MetricRow], threshold: int) -> Table3Comparison:
    """The thesis's Table 3 rows at our FAST threshold and at our point count, and ours per method: median stage
    times, points and frames per second (``templates/thesis_tables.j2`` sets them side by side)."""
    ours = {(t["method"], t["stage"]): t["median_ms"] for t in timings}
    by_method = {r["method"]: r for r in rows}
    used = by_method["thesis"]["valid_per_frame"] if "thesis" in by_method else math.nan
    same_threshold = [row for row in TABLE3 if row[1] == threshold]
    nearest = min(TABLE3, key=lambda row: abs(row[8] - used)) if not math.isnan(used) else None
    ours_rows: list[dict[str, float | str | None]] = []
    for method in ("thesis", "triangulation"):
        found = {stage: ours.get((method, stage)) for stage in ("fast", "flow", "depth")}
        total = ours.get((method, "total"), math.nan)
        row = by_method.get(method)
        ours_rows.append(
            {"method": method, **found, "total": total, "fps": 1e3 / total if total else math.nan}
            | {
                "tracked": row["tracked_per_frame"] if row else None,
                "valid": row["valid_per_frame"] if row else None,
            }
        )
    picked = same_threshold + ([nearest] if nearest and nearest not in same_threshold else [])
    return {"thesis": picked, "ours": ours_rows, "threshold": threshold}


def verdict_rows(sweeps: Sequence[SweepRow], method: str = "thesis") -> list[VerdictRows]:
    """Per variable test FlowNav flew, the thesis's name, levels and verdict beside FlowNav's rows (one method)
    in the thesis's range (``templates/thesis_tables.j2`` words them)."""
    found: list[VerdictRows] = []
    for name, variable, (low, high), levels, verdict in VARIABLE_TESTS:
        rows = [
            r
            for r in sweeps
            if r["variable"] == variable and r["method"] == method and low <= r["value"] <= high
        ]
        if rows:
            found.append(
                {
                    "name": name,
                    "levels": levels,
                    "verdict": verdict,
                    "rows": sorted(rows, key=lambda r: r["value"]),
                }
            )
    return found
