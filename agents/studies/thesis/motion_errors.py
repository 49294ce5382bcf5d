"""The report's section on rotation and translation input error: why the thesis's 8 % verdict and FlowNav's
rows differ, computed from the three-capsule run's measured motion and sweeps."""

from __future__ import annotations

import math
from typing import Any

from agents.studies.thesis.reference import THESIS_FOCAL_PX

# The thesis's breaking point, and the derotation error (px) taken to break depths at this scene's parallax.
BREAKING_ERROR = 0.08
BREAKING_PX = 1.0


def _row(sweeps: list[dict[str, Any]], variable: str, value: float, method: str = "thesis") -> dict[str, Any]:
    for row in sweeps:
        if row["variable"] == variable and row["method"] == method and math.isclose(row["value"], value):
            return row
    return {}


def _pct(value: float | None) -> str:
    return "–" if value is None or math.isnan(value) else f"{100 * value:.1f} %"


def derotation_error_px(focal_px: float, error: float, angle_deg: float) -> float:
    """Upper bound of the pixel shift a relative rotation error causes: ``f · error · θ`` (θ in radians)."""
    return focal_px * error * math.radians(angle_deg)


def angle_for_shift_deg(focal_px: float, error: float, shift_px: float) -> float:
    """The angle θ (degrees) whose relative error ``error`` shifts points by ``shift_px``: ``shift / (f · error)``."""
    return math.degrees(shift_px / (focal_px * error))


def motion_error_section(result: dict[str, Any]) -> list[str]:
    """Markdown section from the three-capsule result (needs its ``motion`` and ``sweeps``)."""
    motion, sweeps = result.get("motion"), result.get("sweeps", [])
    if not motion:
        return []
    f = motion["focal_px"]
    eps = BREAKING_ERROR
    parallax = motion["capsule_parallax_px_median"]
    needed = angle_for_shift_deg(f, eps, BREAKING_PX)
    needed_thesis = angle_for_shift_deg(THESIS_FOCAL_PX, eps, BREAKING_PX)
    readings = [
        ("per-frame rotation (FlowNav's `rotation_error`)", motion["rotation_deg_median"], "rotation_error"),
        (
            "absolute attitude, signed Euler angles (`attitude_rotation_error`)",
            motion["attitude_deg_median"],
            "attitude_rotation_error",
        ),
        (
            "Unity's Euler angles as reported, in [0°, 360°) (−0.5° reads 359.5°)",
            motion["unity_readout_deg_median"],
            None,
        ),
    ]
    lines = [
        "## Rotation and translation error: why the thesis and FlowNav differ",
        "",
        'The thesis found that at 8 % rotation-input error the depths "no longer give accurate information"; '
        f"FlowNav's `rotation_error` rows (section 5, on the same {motion['jitter_deg']:g}° instability run the "
        f"thesis used) rise only to {_pct(_row(sweeps, 'rotation_error', 0.1).get('median_rel_error'))} median "
        "error at 10 %. The difference lies in what the percentage is *of*. A relative error ε on an angle θ "
        f"misplaces the derotated points by up to f · ε · θ pixels (f = {f:.1f} px here: 640 × 480 with a 60° "
        f"vertical field of view; the thesis's f = {THESIS_FOCAL_PX:g} px), and a shift δ against a parallax p "
        "is a relative depth error of about δ / p. Measured on that run "
        f"({motion['frame_pairs']} frame pairs): the camera turns a median {motion['rotation_deg_median']:.2f}° "
        "per frame (per axis pitch, yaw, roll: "
        f"{', '.join(f'{v:.2f}' for v in motion['rotation_axis_deg_median'])}°); its absolute attitude is a "
        f"median {motion['attitude_deg_median']:.2f}° from level along +x (per axis "
        f"{', '.join(f'{v:.2f}' for v in motion['attitude_axis_deg_median'])}°); the capsule points the "
        f"estimator keeps have a median parallax of {parallax:.1f} px (lower quartile "
        f"{motion['capsule_parallax_px_p25']:.1f} px, {motion['capsule_points']} points). So a "
        f"{BREAKING_PX:g} px derotation error is a ≈ {_pct(BREAKING_PX / parallax)} depth error at the median "
        f"capsule point and more at the low-parallax ones: the point where depths stop being informative. For "
        f"{100 * eps:g} % to reach {BREAKING_PX:g} px, θ must be {needed:.2f}° (f = {f:.1f} px; "
        f"{needed_thesis:.2f}° at the thesis's f). The candidate readings:",
        "",
        '| reading of "x % rotation error" | θ the error is relative to (median, deg) | shift at 2 % / 8 % '
        "(px, bound f·ε·θ) | 8 % shift / median capsule parallax | measured at 8 % (`thesis` method): median "
        "error all points / capsule points, within 10 % |",
        "|---|---|---|---|---|",
    ]
    for label, angle, variable in readings:
        low, high = derotation_error_px(f, 0.02, angle), derotation_error_px(f, eps, angle)
        measured = _row(sweeps, variable, eps) if variable else {}
        observed = (
            f"{_pct(measured.get('median_rel_error'))} / {_pct(measured.get('obstacle_median_rel_error'))}, "
            f"{_pct(measured.get('within_10pct'))}"
            if measured
            else "–"
        )
        ratio = high / parallax
        lines.append(
            f"| {label} | {angle:.2f} | {low:.2f} / {high:.2f} | {ratio:.{2 if ratio < 10 else 0}f} | {observed} |"
        )
    lines.append(
        f"| what the thesis's verdict needs (8 % → {BREAKING_PX:g} px) | {needed:.2f} | "
        f"{derotation_error_px(f, 0.02, needed):.2f} / {BREAKING_PX:.2f} | {BREAKING_PX / parallax:.2f} | – |"
    )
    per_frame, attitude = readings[0][1], readings[1][1]
    unity = motion["unity_readout_deg_median"]
    attitude_low = _row(sweeps, "attitude_rotation_error", 0.02)
    lines += [
        "",
        f"*Per-frame rotation* (FlowNav's reading): θ = {per_frame:.2f}° is "
        f"{'below' if per_frame < needed else 'above'} the {needed:.2f}° the verdict needs, so 8 % shifts points "
        f"by at most {derotation_error_px(f, eps, per_frame):.2f} px (about half that on average, the factors "
        "being uniform): the depths spread gradually and do not break, which is what our rows show. *Unity's "
        "[0°, 360°) readout*: a small negative angle reads near 360°, so even 2 % shifts points by "
        f"≈ {derotation_error_px(f, 0.02, unity):.0f} px and wrecks every depth at once, not the gradual spreading "
        "the thesis saw at 2–6 %; that reading is ruled out. *Absolute attitude*: the shift grows with the "
        f"attitude; on our weaving path (≈ {attitude:.1f}°, mostly heading) it is "
        f"{'above' if attitude > needed else 'below'} what the verdict needs, and the depths break earlier than "
        f"in the thesis (at 2 % already {_pct(attitude_low.get('median_rel_error'))} median, "
        f"{_pct(attitude_low.get('within_10pct'))} within 10 %). The thesis's profile (gradual to 6 %, broken at "
        f"8 %) fits an error on angles of about {needed:.1f}°: an attitude error on a nearly level, straight "
        f"flight with ±{motion['jitter_deg']:g}° instability, or per-frame rotations about "
        f"{needed / per_frame:.0f}× ours (the lower-parallax points breaking first). Either way the same "
        "percentage most likely meant a larger angle error in the thesis than in FlowNav's `rotation_error`, "
        "which is why FlowNav finds 8 % a mild spreading and the thesis a breakdown; the thesis's warning holds for attitude-sized errors, as the `attitude_rotation_error` rows show.",
        "",
        *_translation_part(sweeps),
    ]
    return lines


def _translation_part(sweeps: list[dict[str, Any]]) -> list[str]:
    rows = sorted(
        (r for r in sweeps if r["variable"] == "translation_error" and r["method"] == "thesis"),
        key=lambda r: r["value"],
    )
    if not rows:
        return []
    lines = [
        "**Translation error agrees.** Depth is proportional to the told translation, so an error of up to ε on "
        "each component scales the depths by a factor in [1 − ε, 1 + ε]: a median error of about ε / 2 on top "
        "of the error-free one, a band that widens in direct proportion, which is what the thesis saw:",
        "",
        "| translation error ε | expected median ≈ ε / 2 (plus the 0 % row's) | measured median (`thesis`) | "
        "within 10 % | valid points / frame |",
        "|---|---|---|---|---|",
    ]
    base = rows[0]["median_rel_error"] if rows[0]["value"] == 0 else 0.0
    for r in rows:
        expected = r["value"] / 2
        lines.append(
            f"| {100 * r['value']:g} % | {_pct(expected)} (+{_pct(base)}) | {_pct(r['median_rel_error'])} | "
            f"{_pct(r['within_10pct'])} | {r['valid_per_frame']:.0f} |"
        )
    return [*lines, ""]
