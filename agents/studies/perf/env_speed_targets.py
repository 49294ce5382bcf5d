"""The targets of ``env_performance.md``, each worded from the measured rows: env/bare (the throughput target),
env/floor with where the step goes beyond the floor loop (the time-to-policy target), and the real-time factor beside gym-pybullet-drones'."""

from __future__ import annotations

from typing import Any

from agents.common.tables import markdown_table
from agents.studies.perf.env_speed import (
    PYBULLET_DRONES_RTF,
    TARGET_FLOOR_RATIO,
    TARGET_RATIO,
    TARGET_REAL_TIME_FACTOR,
)

# The camera resolution of gym-pybullet-drones' reported real-time factor (PYBULLET_DRONES_RTF).
PYBULLET_DRONES_VISION = (64, 48)


def ratio_target_values(rows: list[dict[str, Any]]) -> dict[str, str | bool]:
    """The env/bare target over the configurations, and whether the floor loop (bare + FAST + one LK pass)
    leaves it reachable at all."""
    default = rows[0]
    ratios = [row["ratio_env_bare"] for row in rows]
    floor = default["ratio_floor_bare"]
    values: dict[str, str | bool] = {
        "target_ratio": str(TARGET_RATIO),
        "ratio_low": f"{min(ratios):.2f}",
        "ratio_high": f"{max(ratios):.2f}",
        "ratio_met": bool(max(ratios) <= TARGET_RATIO),
        "ratio_met_for_some": bool(min(ratios) <= TARGET_RATIO < max(ratios)),
        "ratio_met_configs": ", ".join(
            row["config"] for row in rows if row["ratio_env_bare"] <= TARGET_RATIO
        ),
        "floor": f"{floor:.2f}",
        "floor_low": f"{default['ratio_floor_min']:.2f}",
        "floor_high": f"{default['ratio_floor_max']:.2f}",
        "floor_reaches_target": bool(floor >= TARGET_RATIO),
    }
    if floor < TARGET_RATIO:
        bare_ms = 1e3 / default["steps_per_s_bare"]
        margin = TARGET_RATIO - floor
        own = default["ratio_env_bare"] - floor
        values.update(
            margin=f"{margin:.2f}",
            margin_ms=f"{margin * bare_ms:.2f}",
            own=f"{own:.2f}",
            own_ms=f"{own * bare_ms:.2f}",
        )
    return values


def floor_target_values(rows: list[dict[str, Any]]) -> dict[str, str | bool]:
    """The time-to-policy target, env / floor at the default config, and where the env's step goes beyond the floor
    loop, component by component (median ms per step).

    The floor is the bare loop plus grayscale, FAST and one LK pass; so of the env's stages, rendering is the
    floor's own, physics + controller exceeds the bare loop's physics (bare minus rendering) by the Python
    controller and contact checks, and the estimator exceeds the floor's OpenCV work (floor minus bare) by
    the backward check, the rotation compensation and the depth stage. The parts add up to env − floor.
    """
    default = rows[0]
    bare_physics = default["ms_bare"] - default["ms_render"]
    floor_opencv = default["ms_floor"] - default["ms_bare"]
    parts = [
        (
            "controller and contact checks (physics + controller − the bare loop's physics)",
            default["ms_physics"] - bare_physics,
        ),
        (
            "estimator beyond grayscale + FAST + one LK pass (backward check, rotation compensation, depth)",
            default["ms_estimator"] - floor_opencv,
        ),
        ("ground-truth ray cast", default["ms_ground_truth"]),
        ("rest: sensor model, camera mount, histogram, state, reward, wrappers", default["ms_rest"]),
    ]
    beyond = default["ms_step"] - default["ms_floor"]
    table = markdown_table(
        ["beyond the floor", "ms per step", "share of env − floor"],
        [[name, f"{ms:.2f}", f"{100 * ms / beyond:.0f} %" if beyond > 0 else "-"] for name, ms in parts]
        + [
            [
                "env − floor (sum of the stage medians; the timed blocks' medians differ a little)",
                f"{sum(ms for _, ms in parts):.2f}",
                "",
            ]
        ],
    )
    return {
        "floor_target": str(TARGET_FLOOR_RATIO),
        "floor_target_source": "the time-to-policy target",
        "env_floor": f"{default['ratio_env_floor']:.2f}",
        "env_floor_low": f"{default['ratio_env_floor_min']:.2f}",
        "env_floor_high": f"{default['ratio_env_floor_max']:.2f}",
        "env_floor_met": bool(default["ratio_env_floor"] <= TARGET_FLOOR_RATIO),
        "floor_ms": f"{default['ms_floor']:.2f}",
        "allowed_ms": f"{(TARGET_FLOOR_RATIO - 1) * default['ms_floor']:.2f}",
        "beyond_floor_table": table,
    }


def real_time_values(rows: list[dict[str, Any]]) -> dict[str, str | bool]:
    """The real-time target at the default config, and the smallest resolution beside gym-pybullet-drones."""
    default = rows[0]
    smallest = min(
        [row for row in rows if row["kind"] == "resolution"] or rows,
        key=lambda row: row["width"] * row["height"],
    )
    return {
        "target_real_time": f"{TARGET_REAL_TIME_FACTOR:.0f}",
        "default_real_time": f"{default['real_time_factor_env']:.1f}",
        "real_time_met": bool(default["real_time_factor_env"] >= TARGET_REAL_TIME_FACTOR),
        "default_real_time_bare": f"{default['real_time_factor_bare']:.1f}",
        "pybullet_real_time": str(PYBULLET_DRONES_RTF),
        "pybullet_vision": "×".join(map(str, PYBULLET_DRONES_VISION)),
        "smallest_config": smallest["config"],
        "smallest_real_time": f"{smallest['real_time_factor_env']:.1f}",
        "smallest_real_time_bare": f"{smallest['real_time_factor_bare']:.1f}",
    }
