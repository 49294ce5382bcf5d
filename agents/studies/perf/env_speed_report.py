"""``env_performance.md`` and its figure: steps per second per resolution and FAST threshold against the bare
loop, the per-stage breakdown of a step, and the reasoning behind the env's default resolution and threshold. The prose is ``templates/env_performance.md.j2``;
:func:`env_report_values` computes every figure and verdict it states."""

from __future__ import annotations

import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from agents.common.jinja_reports import render
from agents.common.machine import available_cores
from agents.common.tables import markdown_table, today, write_csv
from agents.evaluation.provenance import gl_renderer, is_software_renderer
from agents.studies.perf.env_speed import (
    DEFAULT_RESOLUTIONS,
    MAX_DEPTH_ERROR_PCT,
    MIN_VALID_PER_SECTOR,
    STAGES,
    measure_env,
)
from agents.studies.perf.env_speed_targets import floor_target_values, ratio_target_values, real_time_values
from agents.studies.perf.timing import hardware_summary

TEMPLATES = Path(__file__).with_name("templates")
PACKAGE = "agents.studies.perf"


def run_env_benchmark(
    resolutions: Sequence[tuple[int, int]] = DEFAULT_RESOLUTIONS,
    steps: int = 100,
    repeats: int = 5,
    seed: int = 0,
    out_dir: str | Path = "results",
    progress: bool = True,
    fast_thresholds: Sequence[int] = (),
) -> list[Path]:
    """Run :func:`measure_env` and write ``env_performance.md``, ``.csv`` and ``.png`` to ``out_dir``.

    Args:
        resolutions, steps, repeats, seed, progress, fast_thresholds: see :func:`measure_env`.
        out_dir: output folder (created).

    Returns:
        The written paths.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    rows = measure_env(resolutions, steps, repeats, seed, progress, fast_thresholds)
    elapsed = time.perf_counter() - started
    command = (
        "flownav bench env --resolutions "
        + ",".join(f"{w}x{h}" for w, h in resolutions)
        + (" --fast-thresholds " + ",".join(map(str, fast_thresholds)) if fast_thresholds else "")
        + f" --steps {steps} --repeats {repeats} --seed {seed} --out {out_dir}"
    )
    csv_path = out_dir / "env_performance.csv"
    plot_path = out_dir / "env_performance.png"
    md_path = out_dir / "env_performance.md"
    write_csv(
        csv_path, [{k: round(v, 4) if isinstance(v, float) else v for k, v in row.items()} for row in rows]
    )
    plot_env_performance(rows[1:], plot_path)
    md_path.write_text(env_report(rows, command, steps, repeats, elapsed))
    return [md_path, csv_path, plot_path]


def plot_env_performance(rows: list[dict[str, Any]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = [row["config"] for row in rows]
    x = np.arange(len(rows))
    figure, (speed_axis, points_axis) = plt.subplots(1, 2, figsize=(11, 4.2))
    bottom = np.zeros(len(rows))
    for key, label in (
        ("ms_physics", "physics + controller"),
        ("ms_render", "render"),
        ("ms_estimator", "estimator"),
        ("ms_ground_truth", "ground-truth ray cast"),
        ("ms_rest", "rest"),
    ):
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
    handles = points_axis.get_legend_handles_labels()
    extra = error_axis.get_legend_handles_labels()
    points_axis.legend(handles[0] + extra[0], handles[1] + extra[1], fontsize=8, loc="center right")
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)


def env_report(rows: list[dict[str, Any]], command: str, steps: int, repeats: int, elapsed: float) -> str:
    """``env_performance.md``: :func:`env_report_values` on this machine, filled into the template.

    Args:
        rows: :func:`measure_env`'s rows, the default config first.
        command: the command line that made the rows.
        steps, repeats: the benchmark's settings.
        elapsed: seconds the benchmark took.

    Returns:
        The Markdown report.
    """
    renderer = gl_renderer()
    values = env_report_values(
        rows,
        command,
        steps,
        repeats,
        elapsed,
        generated=today(),
        hardware=hardware_summary(renderer),
        software_renderer=is_software_renderer(renderer),
        cores=available_cores(),
    )
    return render(PACKAGE, "env_performance.md.j2", values, every_value_used=True)


def env_report_values(
    rows: list[dict[str, Any]],
    command: str,
    steps: int,
    repeats: int,
    elapsed: float,
    *,
    generated: str,
    hardware: str,
    software_renderer: bool,
    cores: int,
) -> dict[str, str | bool]:
    """Every figure, table and verdict of the env report, computed from the measured rows.

    Args:
        rows, command, steps, repeats, elapsed: see :func:`env_report`.
        generated: the report's time stamp.
        hardware: the machine's Markdown list (:func:`hardware_summary`).
        software_renderer: whether MuJoCo rendered on the CPU.
        cores: the cores the benchmark could use.

    Returns:
        The values of ``templates/env_performance.md.j2``: text fields and section conditions.
    """
    default = rows[0]
    return {
        "generated": generated,
        "command": command,
        "elapsed": f"{elapsed:.0f}",
        "steps": str(steps),
        "repeats": str(repeats),
        "hardware": hardware,
        "software_renderer": bool(software_renderer),
        "cores": str(cores),
        "frame_rate": f"{default['frame_rate']:.0f}",
        "substeps": str(default["substeps"]),
        "depth_error_share": f"{100 * default['steps_with_depth_error']:.0f}",
        "table": _speed_table(rows),
        "stage_table": _stage_table(rows),
        **_choice_values(rows),
        **_threshold_values(rows),
        **ratio_target_values(rows),
        **floor_target_values(rows),
        **real_time_values(rows),
    }


def _speed_table(rows: list[dict[str, Any]]) -> str:
    """Steps per second, ratios, real-time factors and estimator output per configuration."""
    header = ["config", "FAST", "steps/s env", "steps/s bare", "env/bare", "floor/bare", "env/floor"]
    header += ["real-time × env"]
    header += ["real-time × bare", "points tracked", "points valid", "depth err. %"]
    return markdown_table(
        header,
        [
            [
                row["config"],
                row["fast_threshold"],
                f"{row['steps_per_s_env']:.1f}",
                f"{row['steps_per_s_bare']:.1f}",
                f"{row['ratio_env_bare']:.2f} ({row['ratio_min']:.2f}–{row['ratio_max']:.2f})",
                f"{row['ratio_floor_bare']:.2f} ({row['ratio_floor_min']:.2f}–{row['ratio_floor_max']:.2f})",
                f"{row['ratio_env_floor']:.2f} ({row['ratio_env_floor_min']:.2f}–{row['ratio_env_floor_max']:.2f})",
                f"{row['real_time_factor_env']:.1f}",
                f"{row['real_time_factor_bare']:.1f}",
                f"{row['points_tracked_median']:.0f}",
                f"{row['points_valid_median']:.0f}",
                f"{row['depth_error_median_pct']:.1f}",
            ]
            for row in rows
        ],
    )


def _stage_table(rows: list[dict[str, Any]]) -> str:
    """Each stage's median ms per step and share of the step, per configuration."""
    return markdown_table(
        ["config", "step ms", "physics + controller", "render", "estimator", "ground-truth ray cast", "rest"],
        [
            [
                row["config"],
                f"{row['ms_step']:.2f}",
                *(
                    f"{row[f'ms_{key}']:.2f} ({100 * row[f'ms_{key}'] / row['ms_step']:.0f} %)"
                    for key in (*STAGES, "rest")
                ),
            ]
            for row in rows
        ],
    )


def _choice_values(rows: list[dict[str, Any]]) -> dict[str, str | bool]:
    """The default-resolution choice: each candidate against the current default, and the criteria."""
    default = rows[0]
    candidates = [row for row in rows if row["kind"] == "resolution"]
    same = [
        row for row in candidates if (row["width"], row["height"]) == (default["width"], default["height"])
    ]
    reference = same[0] if same else default
    min_valid = MIN_VALID_PER_SECTOR * default["histogram_sectors"]

    def meets(row: dict[str, Any]) -> bool:
        return bool(
            row["depth_error_median_pct"] <= MAX_DEPTH_ERROR_PCT and row["points_valid_median"] >= min_valid
        )

    table = markdown_table(
        [
            "resolution",
            "steps/s vs current default",
            "valid points vs current default",
            "meets both criteria",
        ],
        [
            [
                row["config"],
                f"{row['steps_per_s_env'] / reference['steps_per_s_env']:.2f}×",
                f"{row['points_valid_median'] / max(reference['points_valid_median'], 1e-9):.2f}×",
                "yes" if meets(row) else "no",
            ]
            for row in candidates
        ],
    )
    passing = [row for row in candidates if meets(row)]
    values: dict[str, str | bool] = {
        "max_depth_error": f"{MAX_DEPTH_ERROR_PCT:.0f}",
        "min_valid_per_sector": f"{MIN_VALID_PER_SECTOR:.0f}",
        "sectors": str(default["histogram_sectors"]),
        "min_valid": f"{min_valid:.0f}",
        "default_width": str(default["width"]),
        "default_height": str(default["height"]),
        "choice_table": table,
        "any_candidate_meets": bool(passing),
    }
    if passing:
        values["smallest_meeting"] = min(passing, key=lambda row: row["width"] * row["height"])["config"]
    return values


def _threshold_values(rows: list[dict[str, Any]]) -> dict[str, str | bool]:
    """The FAST-threshold section: each threshold against the default config, at the default resolution."""
    default = rows[0]
    thresholds = [row for row in rows if row["kind"] == "fast_threshold"]
    if not thresholds:
        return {"has_thresholds": False}
    table = markdown_table(
        ["FAST threshold", "steps/s vs default", "valid points", "valid points vs default", "depth err. %"],
        [
            [
                row["fast_threshold"],
                f"{default['ratio_env_bare'] / row['ratio_env_bare']:.2f}×",
                f"{row['points_valid_median']:.0f}",
                f"{row['points_valid_median'] / max(default['points_valid_median'], 1e-9):.2f}×",
                f"{row['depth_error_median_pct']:.1f}",
            ]
            for row in sorted([default, *thresholds], key=lambda row: row["fast_threshold"])
        ],
    )
    return {
        "has_thresholds": True,
        "default_threshold": str(default["fast_threshold"]),
        "threshold_table": table,
    }
