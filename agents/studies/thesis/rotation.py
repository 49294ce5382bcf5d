"""Experiment 2 (Table 2): pure rotations; the residual distance after rotation compensation, case by case."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np

from agents.studies.perf.report_kit import saved_figure
from agents.studies.thesis.attitude import unity_order_rotation
from agents.studies.thesis.camera_paths import rotation_path
from agents.studies.thesis.experiment_configs import RotationCase, RotationConfig
from agents.studies.thesis.metrics import rotation_residuals
from agents.studies.thesis.playback_runs import run_playback
from agents.studies.thesis.results import ExperimentResult
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


def _case_row(
    case: RotationCase,
    residuals: list[dict[str, np.ndarray]],
    config: RotationConfig,
    intrinsics: CameraIntrinsics,
) -> dict[str, object]:
    row: dict[str, object] = {
        "case": case.name,
        "frame_pairs": len(residuals),
        "flown_deg": [case.pitch_deg, case.yaw_deg, case.roll_deg],
    }
    if case.thesis is not None:
        row["thesis"] = dataclasses.asdict(case.thesis)
    order_shift = []
    for label, thesis_derotation in (("matrix", False), ("euler", True)):
        compensated, uncompensated, detected = [], [], 0
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
        c = np.concatenate(compensated) if compensated else np.zeros(0)
        u = np.concatenate(uncompensated) if uncompensated else np.zeros(0)
        inliers = c <= config.outlier_px
        row[f"{label}_mean_px"] = float(c.mean()) if len(c) else math.nan
        row[f"{label}_mean_inliers_px"] = float(c[inliers].mean()) if inliers.any() else math.nan
        row[f"{label}_outliers"] = int((~inliers).sum())
        row["uncompensated_mean_px"] = float(u.mean()) if len(u) else math.nan
        row["detected"] = detected
        row["tracked"] = len(c)
    shift = np.concatenate(order_shift) if order_shift else np.zeros(0)
    row["euler_order_shift_px"] = float(shift.mean()) if len(shift) else math.nan
    return row


def _save_figure(table: list[dict[str, Any]], outlier_px: float, file: Path) -> None:
    with saved_figure(file, (10, 3.8)) as fig:
        ax = fig.subplots()
        x = np.arange(len(table))
        thesis = [r.get("thesis") or {} for r in table]
        ax.bar(x - 0.3, [r["matrix_mean_px"] for r in table], 0.2, label="FlowNav, incl. outliers")
        ax.bar(
            x - 0.1,
            [r["matrix_mean_inliers_px"] for r in table],
            0.2,
            label=f"FlowNav, excl. (> {outlier_px:g} px)",
        )
        ax.bar(x + 0.1, [t.get("mean_px", math.nan) for t in thesis], 0.2, label="thesis, incl. outliers")
        ax.bar(
            x + 0.3,
            [math.nan if t.get("mean_inliers_px") is None else t["mean_inliers_px"] for t in thesis],
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
    table = []
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
