"""The figures of the README's section on rotation and translation input error: why the thesis's 8 % verdict
and FlowNav's rows differ, computed from the three-capsule run's measured motion and sweeps."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from agents.pages.wording import pct
from agents.studies.thesis.reference import THESIS_FOCAL_PX
from agents.studies.thesis.results import SweepRow

# The thesis's breaking point, and the derotation error (px) taken to break depths at this scene's parallax.
BREAKING_ERROR = 0.08
BREAKING_PX = 1.0
# The lower error of the readings table: the thesis saw gradual spreading from 2 %.
LOW_ERROR = 0.02
# The readings of "x % rotation error": what the angle is, the motion's median of it, the sweep variable flown.
READINGS = (
    ("per-frame rotation (FlowNav's `rotation_error`)", "rotation_deg_median", "rotation_error"),
    (
        "absolute attitude, signed Euler angles (`attitude_rotation_error`)",
        "attitude_deg_median",
        "attitude_rotation_error",
    ),
    (
        "Unity's Euler angles as reported, in [0°, 360°) (−0.5° reads 359.5°)",
        "unity_readout_deg_median",
        None,
    ),
)


def _row(
    sweeps: Sequence[SweepRow], variable: str, value: float, method: str = "thesis"
) -> SweepRow | dict[str, float]:
    """The sweep's row of ``method`` at ``variable`` = ``value``; empty where it was not flown."""
    for row in sweeps:
        if row["variable"] == variable and row["method"] == method and math.isclose(row["value"], value):
            return row
    return {}


def derotation_error_px(focal_px: float, error: float, angle_deg: float) -> float:
    """Upper bound of the pixel shift a relative rotation error causes: ``f · error · θ`` (θ in radians)."""
    return focal_px * error * math.radians(angle_deg)


def angle_for_shift_deg(focal_px: float, error: float, shift_px: float) -> float:
    """The angle θ (degrees) whose relative error ``error`` shifts points by ``shift_px``: ``shift / (f · error)``."""
    return math.degrees(shift_px / (focal_px * error))


def motion_values(result: Mapping[str, Any]) -> dict[str, object] | None:
    """The section's figures and its tables' rows (``templates/thesis_tables.j2`` words them) from the
    three-capsule result (its ``motion`` and ``sweeps``); None without a measured motion."""
    motion, sweeps = result.get("motion"), result.get("sweeps", [])
    if not motion:
        return None
    f, eps, parallax = motion["focal_px"], BREAKING_ERROR, motion["capsule_parallax_px_median"]
    needed = angle_for_shift_deg(f, eps, BREAKING_PX)
    readings = [
        {"label": label, "angle": motion[key], "measured": _row(sweeps, variable, eps) if variable else {}}
        | {
            "low": derotation_error_px(f, LOW_ERROR, motion[key]),
            "high": derotation_error_px(f, eps, motion[key]),
        }
        for label, key, variable in READINGS
    ]
    return {
        "run": motion,
        "needed": needed,
        "error_at_10pct": pct(_row(sweeps, "rotation_error", 0.1).get("median_rel_error")),
        "breaking_px": f"{BREAKING_PX:g}",
        "breaking_pct": f"{100 * eps:g}",
        "breaking_depth_error": pct(BREAKING_PX / parallax),
        "needed_thesis_deg": f"{angle_for_shift_deg(THESIS_FOCAL_PX, eps, BREAKING_PX):.2f}",
        "readings": [r | {"ratio": r["high"] / parallax} for r in readings],
        "needed_low": derotation_error_px(f, LOW_ERROR, needed),
        "needed_ratio": BREAKING_PX / parallax,
        "per_frame_shift": f"{derotation_error_px(f, eps, motion['rotation_deg_median']):.2f}",
        "unity_shift": f"{derotation_error_px(f, LOW_ERROR, motion['unity_readout_deg_median']):.0f}",
        "attitude_low": _row(sweeps, "attitude_rotation_error", LOW_ERROR),
        "translation_rows": sorted(
            (r for r in sweeps if r["variable"] == "translation_error" and r["method"] == "thesis"),
            key=lambda r: r["value"],
        ),
    }
