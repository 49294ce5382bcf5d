"""Experiment 2 (Table 2): pure rotations; the residual distance after rotation compensation, case by case."""

from __future__ import annotations

import math
from pathlib import Path
from typing import NamedTuple

import numpy as np

from agents.studies.perf.report_kit import saved_figure
from agents.studies.thesis.attitude import unity_order_rotation
from agents.studies.thesis.camera_paths import rotation_path
from agents.studies.thesis.experiment_configs import RotationCase, RotationConfig
from agents.studies.thesis.metrics import rotation_residuals
from agents.studies.thesis.playback_runs import run_playback
from agents.studies.thesis.results import ExperimentResult, Table2Row
from estimator import CameraIntrinsics
from estimator.geometry import derotate, euler_zyx_to_rotation
from flownav_env.playback import PlaybackSettings, PlaybackWorld


def euler_order_shift_px(points: np.ndarray, case: RotationCase, intrinsics: CameraIntrinsics) -> np.ndarray:
    """How far the case's angles composed in the thesis's Z-Y-X order (eq. 4.15) move each point from the
    same angles composed in Unity's order (z, then x, then y), in pixels: what an Euler-order mix-up costs."""
    angles = np.deg2rad([case.pitch_deg, case.yaw_deg, case.roll_deg])
    normalized = intrinsics.normalize(np.asarray(points, np.float64).reshape(-1, 2))
    unity, _ = derotate(normalized, unity_order_rotation(*angles))
    zyx, _ = derotate(normalized, euler_zyx_to_rotation(*angles))
    return np.linalg.norm(intrinsics.denormalize(unity) - intrinsics.denormalize(zyx), axis=1)


class _Pass(NamedTuple):
    """One compensation pass over a case's frame pairs: the residuals compensated and not (px), the points
    detected, and (the exact rotation's pass) what an Euler-order mix-up moves each point."""

    compensated: np.ndarray
    uncompensated: np.ndarray
    detected: int
    order_shift: list[np.ndarray]


def _compensation_pass(
    case: RotationCase,
    residuals: list[dict[str, np.ndarray]],
    intrinsics: CameraIntrinsics,
    thesis_derotation: bool,
) -> _Pass:
    compensated, uncompensated, detected, order_shift = [], [], 0, []
    for frame in residuals:
        tracked = np.asarray(frame["tracked"], bool)
        detected += len(tracked)
        c, u = rotation_residuals(
            frame["points"][tracked],
            frame["next_points"][tracked],
            frame["rotation"],
            intrinsics,
            thesis_derotation,
        )
        compensated.append(c)
        uncompensated.append(u)
        if not thesis_derotation:
            order_shift.append(euler_order_shift_px(frame["points"][tracked], case, intrinsics))
    return _Pass(
        np.concatenate(compensated) if compensated else np.zeros(0),
        np.concatenate(uncompensated) if uncompensated else np.zeros(0),
        detected,
        order_shift,
    )


def _mean(values: np.ndarray) -> float:
    return float(values.mean()) if len(values) else math.nan


def _case_row(
    case: RotationCase,
    residuals: list[dict[str, np.ndarray]],
    config: RotationConfig,
    intrinsics: CameraIntrinsics,
) -> Table2Row:
    matrix, euler = (_compensation_pass(case, residuals, intrinsics, thesis) for thesis in (False, True))
    matrix_inliers, euler_inliers = (p.compensated <= config.outlier_px for p in (matrix, euler))
    shift = np.concatenate(matrix.order_shift) if matrix.order_shift else np.zeros(0)
    row: Table2Row = {
        "case": case.name,
        "frame_pairs": len(residuals),
        "flown_deg": [case.pitch_deg, case.yaw_deg, case.roll_deg],
        "matrix_mean_px": _mean(matrix.compensated),
        "matrix_mean_inliers_px": _mean(matrix.compensated[matrix_inliers]),
        "matrix_outliers": int((~matrix_inliers).sum()),
        # The uncompensated residual and the counts are the last pass's, as the rows have always kept them.
        "uncompensated_mean_px": _mean(euler.uncompensated),
        "detected": euler.detected,
        "tracked": len(euler.compensated),
        "euler_mean_px": _mean(euler.compensated),
        "euler_mean_inliers_px": _mean(euler.compensated[euler_inliers]),
        "euler_outliers": int((~euler_inliers).sum()),
        "euler_order_shift_px": _mean(shift),
    }
    if case.thesis is not None:
        quoted = case.thesis
        row["thesis"] = {
            "test": quoted.test,
            "unity_deg": list(quoted.unity_deg),
            "mean_px": quoted.mean_px,
            "mean_inliers_px": quoted.mean_inliers_px,
            "points": quoted.points,
            "points_inliers": quoted.points_inliers,
        }
    return row


def _save_figure(table: list[Table2Row], outlier_px: float, file: Path) -> None:
    with saved_figure(file, (10, 3.8)) as fig:
        ax = fig.subplots()
        x = np.arange(len(table))
        quotes = [r.get("thesis") for r in table]
        ax.bar(x - 0.3, [r["matrix_mean_px"] for r in table], 0.2, label="FlowNav, incl. outliers")
        ax.bar(
            x - 0.1,
            [r["matrix_mean_inliers_px"] for r in table],
            0.2,
            label=f"FlowNav, excl. (> {outlier_px:g} px)",
        )
        ax.bar(
            x + 0.1,
            [math.nan if q is None else q["mean_px"] for q in quotes],
            0.2,
            label="thesis, incl. outliers",
        )
        ax.bar(
            x + 0.3,
            [math.nan if q is None or q["mean_inliers_px"] is None else q["mean_inliers_px"] for q in quotes],
            0.2,
            label="thesis, excl. outliers",
        )
        ax.set_yscale("log")
        ax.set_xticks(x, [r["case"] for r in table], rotation=30, ha="right", fontsize=8)
        ax.set_ylabel("mean |p2 - p2′| (px)")
        ax.set_title(
            "Rotation compensation on pure rotations (Table 2): FlowNav beside the thesis", fontsize=10
        )
        ax.legend(fontsize=7, ncol=2)
        ax.grid(alpha=0.3, axis="y")


def run_rotation(config: RotationConfig, out_dir: Path, progress: bool = True) -> ExperimentResult:
    """Experiment 2 (Table 2): pure rotations; residual distance after rotation compensation."""
    intrinsics = CameraIntrinsics.from_fov(config.camera.width, config.camera.height, config.camera.fov_deg)
    table: list[Table2Row] = []
    world = None
    try:
        for case in config.cases:
            path = rotation_path(config, case)
            if world is None:
                world = PlaybackWorld(path, config.camera.width, config.camera.height, config.camera.fov_deg)
            result = run_playback(
                path,
                world,
                PlaybackSettings(seed=config.seed),
                config.estimator,
                keep_residuals=True,
                progress=progress,
                description=f"rotation {case.name}",
            )
            table.append(_case_row(case, result.residuals, config, intrinsics))
    finally:
        if world is not None:
            world.close()
    _save_figure(table, config.outlier_px, out_dir / "rotation.png")
    return {"table2": table, "rows": [], "figures": ["rotation.png"], "focal_px": float(intrinsics.fx)}
