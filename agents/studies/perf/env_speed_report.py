"""``env_performance.md`` and its figure: steps per second per resolution against the bare loop, the per-stage
breakdown of a step, and the targets: env/bare (throughput), env/floor with where the step goes beyond the floor loop (time to a policy)
and the real-time factor beside gym-pybullet-drones'. The prose is ``templates/env_performance.md.j2``;
:func:`env_report_values` computes every figure and verdict it states."""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from agents.common.tables import markdown_table, write_csv
from agents.studies.perf.env_speed import (
    DEFAULT_RESOLUTIONS,
    PYBULLET_DRONES_RTF,
    PYBULLET_DRONES_VISION,
    TARGET_FLOOR_RATIO,
    TARGET_RATIO,
    TARGET_REAL_TIME_FACTOR,
    measure_env,
)
from agents.studies.perf.report_kit import RunFacts, rounded, saved_figure, table, write_report
from flownav_env.stage_timing import STAGES

Row = dict[str, Any]
# The stacked bars of the figure: a step's stages, bottom to top.
STAGE_LABELS = {
    "ms_physics": "physics + controller",
    "ms_render": "render",
    "ms_estimator": "estimator",
    "ms_ground_truth": "ground-truth ray cast",
    "ms_rest": "rest",
}


def run_env_benchmark(
    resolutions: Sequence[tuple[int, int]] = DEFAULT_RESOLUTIONS,
    steps: int = 100,
    repeats: int = 5,
    seed: int = 0,
    out_dir: str | Path = "results",
    progress: bool = True,
) -> list[Path]:
    """Run :func:`measure_env` and write ``env_performance.md``, ``.csv`` and ``.png`` to ``out_dir`` (created);
    the arguments are :func:`measure_env`'s. Returns the written paths."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    command = (
        "flownav bench env --resolutions "
        + ",".join(f"{w}x{h}" for w, h in resolutions)
        + f" --steps {steps} --repeats {repeats} --seed {seed} --out {out_dir}"
    )
    started = time.perf_counter()
    rows = measure_env(resolutions, steps, repeats, seed, progress)
    run = RunFacts.of_this_run(command, started)
    paths = [out_dir / f"env_performance.{ext}" for ext in ("md", "csv", "png")]
    write_csv(paths[1], rounded(rows))
    plot_env_performance(rows[1:], paths[2])
    write_report(paths[0], "env_performance.md.j2", env_report_values(rows, steps, repeats, run))
    return paths


def plot_env_performance(rows: list[Row], path: Path) -> None:
    """Time per step by stage beside the bare loop (left); points per frame and depth error (right)."""
    labels = [row["config"] for row in rows]
    x = np.arange(len(rows))
    with saved_figure(path, (11, 4.2)) as figure:
        speed_axis, points_axis = figure.subplots(1, 2)
        bottom = np.zeros(len(rows))
        for key, label in STAGE_LABELS.items():
            values = np.array([row[key] for row in rows])
            speed_axis.bar(x, values, bottom=bottom, label=label)
            bottom += values
        speed_axis.plot(x, [1e3 / row["steps_per_s_bare"] for row in rows], "k*--", label="bare MuJoCo loop")
        speed_axis.set_xticks(x, labels, rotation=30)
        speed_axis.set_ylabel("ms per step (median)")
        speed_axis.set_title("Time per env step by stage")
        speed_axis.legend(fontsize=8)
        points_axis.plot(x, [row["points_tracked_median"] for row in rows], "o-", label="points tracked")
        points_axis.plot(x, [row["points_valid_median"] for row in rows], "s-", label="points valid")
        points_axis.set_xticks(x, labels, rotation=30)
        points_axis.set_ylabel("points per frame (median)")
        points_axis.set_yscale("log")
        error_axis = points_axis.twinx()
        error_axis.plot(x, [row["depth_error_median_pct"] for row in rows], "r^:", label="median depth error")
        error_axis.set_ylabel("median relative depth error (%)", color="r")
        points_axis.set_title("Estimator output per configuration")
        handles, names = points_axis.get_legend_handles_labels()
        more_handles, more_names = error_axis.get_legend_handles_labels()
        points_axis.legend(handles + more_handles, names + more_names, fontsize=8, loc="center right")


@dataclass(frozen=True)
class RatioTargetValues:
    """The env/bare target over the configurations (:func:`_ratio_target_values`), and whether the floor loop
    leaves it reachable at all; where it does, the margin it leaves and what FlowNav adds (else None)."""

    target_ratio: str
    ratio_low: str
    ratio_high: str
    ratio_met: bool
    ratio_met_for_some: bool
    ratio_met_configs: str
    floor: str
    floor_low: str
    floor_high: str
    floor_reaches_target: bool
    margin: str | None
    margin_ms: str | None
    own: str | None
    own_ms: str | None


@dataclass(frozen=True)
class FloorTargetValues:
    """The time-to-policy target (:func:`_floor_target_values`): env / floor at the default config, and where
    the env's step goes beyond the floor loop."""

    floor_target: str
    env_floor: str
    env_floor_low: str
    env_floor_high: str
    env_floor_met: bool
    floor_ms: str
    allowed_ms: str
    beyond_floor_table: str


@dataclass(frozen=True)
class RealTimeValues:
    """The real-time target at the default config, and the smallest resolution beside gym-pybullet-drones
    (:func:`_real_time_values`)."""

    target_real_time: str
    default_real_time: str
    real_time_met: bool
    default_real_time_bare: str
    pybullet_real_time: str
    pybullet_vision: str
    smallest_config: str
    smallest_real_time: str
    smallest_real_time_bare: str


@dataclass(frozen=True)
class EnvPerformanceValues(RealTimeValues, FloorTargetValues, RatioTargetValues):
    """Every value ``templates/env_performance.md.j2`` words (:func:`env_report_values`)."""

    run: RunFacts
    steps: str
    repeats: str
    frame_rate: str
    substeps: str
    depth_error_share: str
    table: str
    stage_table: str


def env_report_values(rows: list[Row], steps: int, repeats: int, run: RunFacts) -> EnvPerformanceValues:
    """Every figure, table and verdict of the report, from :func:`measure_env`'s rows (the default config
    first), its steps and repeats, and the run's facts."""
    default = rows[0]
    # Each part is handed on whole, by its fields (``vars``: shallow, as the template is given them).
    return EnvPerformanceValues(
        **vars(_ratio_target_values(rows)),
        **vars(_floor_target_values(default)),
        **vars(_real_time_values(rows)),
        run=run,
        steps=str(steps),
        repeats=str(repeats),
        frame_rate=f"{default['frame_rate']:.0f}",
        substeps=str(default["substeps"]),
        depth_error_share=f"{100 * default['steps_with_depth_error']:.0f}",
        table=_speed_table(rows),
        stage_table=_stage_table(rows),
    )


def _speed_table(rows: list[Row]) -> str:
    """Steps per second, ratios, real-time factors and estimator output per configuration."""
    columns = {
        "config": "{config}",
        "FAST": "{fast_threshold}",
        "steps/s env": "{steps_per_s_env:.1f}",
        "steps/s bare": "{steps_per_s_bare:.1f}",
        "env/bare": "{ratio_env_bare:.2f} ({ratio_min:.2f}–{ratio_max:.2f})",
        "floor/bare": "{ratio_floor_bare:.2f} ({ratio_floor_min:.2f}–{ratio_floor_max:.2f})",
        "env/floor": "{ratio_env_floor:.2f} ({ratio_env_floor_min:.2f}–{ratio_env_floor_max:.2f})",
        "real-time × env": "{real_time_factor_env:.1f}",
        "real-time × bare": "{real_time_factor_bare:.1f}",
        "points tracked": "{points_tracked_median:.0f}",
        "points valid": "{points_valid_median:.0f}",
        "depth err. %": "{depth_error_median_pct:.1f}",
    }
    return table(rows, columns)


def _stage_table(rows: list[Row]) -> str:
    """Each stage's median ms per step and share of the step, per configuration."""
    shares = [
        {**row, **{f"share_{key}": 100 * row[f"ms_{key}"] / row["ms_step"] for key in (*STAGES, "rest")}}
        for row in rows
    ]
    columns = {"config": "{config}", "step ms": "{ms_step:.2f}"}
    for key, label in STAGE_LABELS.items():
        columns[label] = f"{{{key}:.2f}} ({{share_{key[3:]}:.0f}} %)"
    return table(shares, columns)


def _ratio_target_values(rows: list[Row]) -> RatioTargetValues:
    """The env/bare target over the configurations, and whether the floor loop (bare + FAST + one LK pass)
    leaves it reachable at all."""
    default = rows[0]
    ratios = [row["ratio_env_bare"] for row in rows]
    floor = default["ratio_floor_bare"]
    reachable = floor < TARGET_RATIO
    bare_ms = 1e3 / default["steps_per_s_bare"]
    margin, own = TARGET_RATIO - floor, default["ratio_env_bare"] - floor
    return RatioTargetValues(
        target_ratio=str(TARGET_RATIO),
        ratio_low=f"{min(ratios):.2f}",
        ratio_high=f"{max(ratios):.2f}",
        ratio_met=bool(max(ratios) <= TARGET_RATIO),
        ratio_met_for_some=bool(min(ratios) <= TARGET_RATIO < max(ratios)),
        ratio_met_configs=", ".join(row["config"] for row in rows if row["ratio_env_bare"] <= TARGET_RATIO),
        floor=f"{floor:.2f}",
        floor_low=f"{default['ratio_floor_min']:.2f}",
        floor_high=f"{default['ratio_floor_max']:.2f}",
        floor_reaches_target=bool(floor >= TARGET_RATIO),
        margin=f"{margin:.2f}" if reachable else None,
        margin_ms=f"{margin * bare_ms:.2f}" if reachable else None,
        own=f"{own:.2f}" if reachable else None,
        own_ms=f"{own * bare_ms:.2f}" if reachable else None,
    )


def _floor_target_values(default: Row) -> FloorTargetValues:
    """The time-to-policy target, env / floor at the default config, and where the env's step goes beyond the
    floor loop, component by component (median ms per step).

    The floor is the bare loop plus grayscale, FAST and one LK pass; so of the env's stages, rendering is the
    floor's own, physics + controller exceeds the bare loop's physics (bare minus rendering) by the Python
    controller and contact checks, and the estimator exceeds the floor's OpenCV work (floor minus bare) by
    the backward check, the rotation compensation and the depth stage. The parts add up to env − floor.
    """
    parts = {
        "controller and contact checks (physics + controller − the bare loop's physics)": default[
            "ms_physics"
        ]
        - (default["ms_bare"] - default["ms_render"]),
        "estimator beyond grayscale + FAST + one LK pass (backward check, rotation compensation, depth)": default[
            "ms_estimator"
        ]
        - (default["ms_floor"] - default["ms_bare"]),
        "ground-truth ray cast": default["ms_ground_truth"],
        "rest: sensor model, camera mount, histogram, state, reward, wrappers": default["ms_rest"],
    }
    beyond = default["ms_step"] - default["ms_floor"]
    lines = [
        [name, f"{ms:.2f}", f"{100 * ms / beyond:.0f} %" if beyond > 0 else "-"] for name, ms in parts.items()
    ]
    total = "env − floor (sum of the stage medians; the timed blocks' medians differ a little)"
    lines.append([total, f"{sum(parts.values()):.2f}", ""])
    return FloorTargetValues(
        floor_target=str(TARGET_FLOOR_RATIO),
        env_floor=f"{default['ratio_env_floor']:.2f}",
        env_floor_low=f"{default['ratio_env_floor_min']:.2f}",
        env_floor_high=f"{default['ratio_env_floor_max']:.2f}",
        env_floor_met=bool(default["ratio_env_floor"] <= TARGET_FLOOR_RATIO),
        floor_ms=f"{default['ms_floor']:.2f}",
        allowed_ms=f"{(TARGET_FLOOR_RATIO - 1) * default['ms_floor']:.2f}",
        beyond_floor_table=markdown_table(["beyond the floor", "ms per step", "share of env − floor"], lines),
    )


def _real_time_values(rows: list[Row]) -> RealTimeValues:
    """The real-time target at the default config, and the smallest resolution beside gym-pybullet-drones."""
    default = rows[0]
    smallest = min(rows[1:] or rows, key=lambda row: row["width"] * row["height"])
    return RealTimeValues(
        target_real_time=f"{TARGET_REAL_TIME_FACTOR:.0f}",
        default_real_time=f"{default['real_time_factor_env']:.1f}",
        real_time_met=bool(default["real_time_factor_env"] >= TARGET_REAL_TIME_FACTOR),
        default_real_time_bare=f"{default['real_time_factor_bare']:.1f}",
        pybullet_real_time=str(PYBULLET_DRONES_RTF),
        pybullet_vision="×".join(map(str, PYBULLET_DRONES_VISION)),
        smallest_config=smallest["config"],
        smallest_real_time=f"{smallest['real_time_factor_env']:.1f}",
        smallest_real_time_bare=f"{smallest['real_time_factor_bare']:.1f}",
    )
