"""Experiment 5 (Figs. 41–43, Appendices C–H): the recorded three-capsule flight, its base run and one sweep per
test variable, plus the motion measurements that the rotation-error analysis of the report rests on."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np

from agents.studies.perf.report_kit import saved_figure
from agents.studies.thesis.attitude import unity_angles
from agents.studies.thesis.camera_paths import record_three_capsule_flight, scene_kwargs
from agents.studies.thesis.experiment_configs import ThreeCapsuleConfig
from agents.studies.thesis.figures import save_depth_figure
from agents.studies.thesis.metrics import METHODS, MetricRow, metric_rows
from agents.studies.thesis.playback_runs import RunResult, run_playback
from agents.studies.thesis.results import ExperimentResult, MotionMeasure, SweepRow
from estimator import CameraIntrinsics
from estimator.geometry import derotate
from flownav_env.playback import PlaybackSettings, PlaybackWorld, save_path
from flownav_env.rotations import camera_rotation, vector_from_rotation

# These variables are matched to Appendices C–H only as a group, not one by one, so no letter is given.
SWEEP_VARIABLES = (
    ("attitude_jitter_deg", "angular instability (deg per frame)"),
    ("distance_per_frame", "distance per frame (m)"),
    ("brightness", "brightness (1 = daylight)"),
    ("rotation_error", "rotation error (relative)"),
    ("translation_error", "translation error (relative)"),
    ("attitude_rotation_error", "rotation error on the attitude (relative)"),
)
# These run on the thesis's 0.5 deg instability run (config rotation_error_jitter_deg), as the thesis's did.
ROTATION_ERROR_VARIABLES = ("rotation_error", "attitude_rotation_error")


def measure_motion(result: RunResult, intrinsics: CameraIntrinsics, jitter_deg: float) -> MotionMeasure:
    """What a relative rotation error is relative to, and the parallax it competes with, on one run flown with
    ``jitter_deg`` of angular instability.

    Needs ``result`` from :func:`run_playback` with ``keep_residuals``. Returns medians over frame pairs of the
    per-frame rotation (angle and per axis) and of the absolute attitude (signed Euler angles as Unity would
    order them, and as Unity reports them in [0°, 360°)), and the median and lower-quartile parallax (pixels,
    after derotation with the true rotation) of the thesis method's valid points on a capsule.
    """
    level = camera_rotation(0.0)
    rotations, attitudes, parallax = [], [], []
    for frame, residual in zip(result.methods["thesis"], result.residuals, strict=True):
        rotations.append(np.rad2deg(vector_from_rotation(residual["true_rotation"])))
        attitudes.append(np.rad2deg(unity_angles(level.T @ residual["attitude"])))
        on_capsule = np.asarray(frame["valid"], bool) & (np.asarray(frame["labels"]) >= 0)
        derotated, _ = derotate(
            intrinsics.normalize(residual["points"][on_capsule]), residual["true_rotation"]
        )
        shift = residual["next_points"][on_capsule] - intrinsics.denormalize(derotated)
        parallax.append(np.linalg.norm(shift, axis=1))
    rotation, attitude, flow = np.array(rotations), np.array(attitudes), np.concatenate(parallax)
    return {
        "focal_px": float(intrinsics.fx),
        "frame_pairs": len(rotation),
        "rotation_deg_median": float(np.median(np.linalg.norm(rotation, axis=1))),
        "rotation_axis_deg_median": np.median(np.abs(rotation), axis=0).tolist(),
        "attitude_deg_median": float(np.median(np.linalg.norm(attitude, axis=1))),
        "attitude_axis_deg_median": np.median(np.abs(attitude), axis=0).tolist(),
        "unity_readout_deg_median": float(np.median(np.mod(attitude, 360.0))),
        "capsule_parallax_px_median": float(np.median(flow)) if len(flow) else float("nan"),
        "capsule_parallax_px_p25": float(np.percentile(flow, 25)) if len(flow) else float("nan"),
        "capsule_points": len(flow),
        "jitter_deg": jitter_deg,
    }


def _sweep_figure(sweeps: list[SweepRow], file: Path) -> None:
    with saved_figure(file, (3.2 * len(SWEEP_VARIABLES), 5.6)) as fig:
        axes = fig.subplots(2, len(SWEEP_VARIABLES), squeeze=False)
        fig.suptitle(
            "Three capsules: one test variable changed from the base run (Appendices C–H)", fontsize=10
        )
        for column, (variable, label) in enumerate(SWEEP_VARIABLES):
            for method, marker in zip(METHODS, ("o", "s"), strict=True):
                points = [r for r in sweeps if r["variable"] == variable and r["method"] == method]
                values = [r["value"] for r in points]
                axes[0, column].plot(
                    values, [100 * r["median_rel_error"] for r in points], marker=marker, label=method
                )
                axes[1, column].plot(
                    values, [r["valid_per_frame"] for r in points], marker=marker, label=method
                )
            axes[0, column].set_title(label, fontsize=8)
            axes[1, column].set_xlabel(label, fontsize=8)
            if variable == "distance_per_frame":
                axes[0, column].set_xscale("log")
                axes[1, column].set_xscale("log")
            for row in range(2):
                axes[row, column].grid(alpha=0.3)
        axes[0, 0].set_ylabel("median |rel. depth error| (%)")
        axes[1, 0].set_ylabel("valid points per frame")
        axes[0, 0].legend(fontsize=8)


def run_three_capsule(config: ThreeCapsuleConfig, out_dir: Path, progress: bool = True) -> ExperimentResult:
    """Experiment 5 (Figs. 41–43, Appendices C–H): recorded flight, base run, one sweep per variable."""
    path = record_three_capsule_flight(config)
    if config.obstacles:
        # An explicit capsule list in the config overrides the env layout's capsules for the playback.
        scene = scene_kwargs(config)
        path.obstacles, path.materials = scene["obstacles"], scene["materials"]
    save_path(path, out_dir / "three_capsule_path.npz")
    base = dataclasses.asdict(config.base)
    camera = config.camera
    world = PlaybackWorld(path, camera.width, camera.height, camera.fov_deg)
    rows: list[MetricRow] = []
    sweeps: list[SweepRow] = []

    def play(settings: dict[str, Any], label: str, residuals: bool = False, error: float = 0.0) -> RunResult:
        playback = PlaybackSettings(seed=config.seed, **settings)
        return run_playback(
            path,
            world,
            playback,
            config.estimator,
            keep_residuals=residuals,
            attitude_error=error,
            progress=progress,
            description=label,
        )

    try:
        base_result = play(base, "three base")
        rows += metric_rows("base", base_result.methods, METHODS)
        unsteady = {**base, "attitude_jitter_deg": config.rotation_error_jitter_deg}
        motion = measure_motion(
            play(unsteady, "three motion", residuals=True),
            CameraIntrinsics.from_fov(camera.width, camera.height, camera.fov_deg),
            config.rotation_error_jitter_deg,
        )
        for variable, _label in SWEEP_VARIABLES:
            for value in getattr(config.sweeps, variable):
                settings = {**(unsteady if variable in ROTATION_ERROR_VARIABLES else base)}
                attitude_error = value if variable == "attitude_rotation_error" else 0.0
                if variable != "attitude_rotation_error":
                    settings[variable] = value
                if settings["distance_per_frame"] > path.arc_length()[-1]:
                    continue
                result = play(settings, f"{variable}={value:g}", error=attitude_error)
                for row in metric_rows(f"{variable}={value:g}", result.methods, METHODS):
                    sweeps.append({"variable": variable, "value": value, **row})
    finally:
        world.close()
    base_figure = save_depth_figure(
        [(method, base_result.methods[method], base_result.references) for method in METHODS],
        out_dir / "three_capsule_base.png",
        f"Three capsules, base run ({config.base.distance_per_frame} m/frame)",
    )
    _sweep_figure(sweeps, out_dir / "three_capsule_sweeps.png")
    return {
        "rows": rows,
        "sweeps": sweeps,
        "motion": motion,
        "figures": [base_figure.name, "three_capsule_sweeps.png"],
        "recorded_frames": len(path),
        "recorded_length_m": float(path.arc_length()[-1]),
        "obstacles": path.obstacles.tolist(),
    }
