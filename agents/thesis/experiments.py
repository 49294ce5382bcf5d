"""The thesis's estimator experiments (§5) replayed in FlowNav, with the error figures the thesis lacked.

Five experiments, each a typed config (``configs/thesis/<name>.yaml``) and a runner returning a JSON-ready
result and writing figures:

1. ``straight``: straight flight along the optical axis toward one capsule; depth from x-flow, y-flow,
   bidirectional flow (thesis method) and triangulation (Figs. 22–24).
2. ``rotation``: pure rotations (Table 2): distance between the tracked point p2 and the derotated point p2′.
3. ``translation``: x then y translation past one capsule and past four (Figs. 33, 35).
4. ``random6dof``: a human-like random 6-DoF path in front of one capsule (Fig. 38) and the per-stage timings
   (Table 3).
5. ``three_capsule``: a recorded flight through the three-capsule scene (Figs. 41–43), base run and sweeps of
   each test variable (Appendices C–H).

Both depth methods of :class:`estimator.FlowDepthEstimator` (``"thesis"``, ``"triangulation"``) run on the same
rendered frames. Ground truth is the exact z-depth by ray casting at every keypoint.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from agents.thesis.configs import (
    ExperimentConfig,
    Random6DofConfig,
    RotationConfig,
    StraightConfig,
    ThreeCapsuleConfig,
    TranslationConfig,
)
from agents.thesis.figures import save_depth_figure
from agents.thesis.metrics import METHODS, depth_metrics, rotation_residuals
from agents.thesis.paths import (
    random_6dof_path,
    record_three_capsule_flight,
    rotation_path,
    scene_kwargs,
    straight_path,
    translation_path,
)
from agents.thesis.playback_runs import RunResult, run_playback
from flownav_env.playback import PlaybackSettings, PlaybackWorld, save_path


def _settings(config: ExperimentConfig, **kwargs: Any) -> Any:

    return PlaybackSettings(seed=config.seed, **kwargs)


def _world(path: Any, config: ExperimentConfig) -> Any:

    return PlaybackWorld(path, config.camera.width, config.camera.height, config.camera.fov_deg)


def _metric_rows(run: str, result: RunResult, names: Iterable[str]) -> list[dict[str, Any]]:
    rows = []
    for name in names:
        frames = result.methods[name]
        row = {"run": run, "method": name, **depth_metrics(frames)}
        obstacle = depth_metrics(frames, obstacles_only=True)
        row["obstacle_median_rel_error"] = obstacle["median_rel_error"]
        row["obstacle_valid_per_frame"] = obstacle["valid_per_frame"]
        rows.append(row)
    return rows


def run_straight(config: StraightConfig, out_dir: Path, progress: bool = True) -> dict[str, Any]:
    """Experiment 1 (Figs. 22–24): straight flight toward one capsule; four depth variants."""
    path = straight_path(config)
    world = _world(path, config)
    try:
        result = run_playback(
            path,
            world,
            _settings(config),
            config.estimator,
            component_variants=True,
            progress=progress,
            description="straight",
        )
    finally:
        world.close()
    names = ["x-flow", "y-flow", "thesis", "triangulation"]
    titles = {
        "x-flow": "x-flow only (Fig. 22)",
        "y-flow": "y-flow only (Fig. 23)",
        "thesis": "bidirectional, larger component (thesis method, Fig. 24)",
        "triangulation": "triangulation (both components, least squares)",
    }
    figure = save_depth_figure(
        [(titles[n], result.methods[n], result.references) for n in names],
        out_dir / "straight.png",
        f"Straight flight toward one capsule, {config.distance_per_frame} m/frame",
    )
    return {"rows": _metric_rows("straight", result, names), "figures": [figure.name]}


def run_rotation(config: RotationConfig, out_dir: Path, progress: bool = True) -> dict[str, Any]:
    """Experiment 2 (Table 2): pure rotations; residual distance after rotation compensation."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from estimator import CameraIntrinsics

    intrinsics = CameraIntrinsics.from_fov(config.camera.width, config.camera.height, config.camera.fov_deg)
    table = []
    world = None
    try:
        for case in config.cases:
            path = rotation_path(config, case)
            if world is None:
                world = _world(path, config)
            result = run_playback(
                path,
                world,
                _settings(config),
                config.estimator,
                keep_residuals=True,
                progress=progress,
                description=f"rotation {case.name}",
            )
            row: dict[str, Any] = {"case": case.name}
            for label, thesis_derotation in (("matrix", False), ("euler", True)):
                compensated, uncompensated, detected = [], [], 0
                for frame in result.residuals:
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
                c = np.concatenate(compensated) if compensated else np.zeros(0)
                u = np.concatenate(uncompensated) if uncompensated else np.zeros(0)
                inliers = c <= config.outlier_px
                row[f"{label}_mean_px"] = float(c.mean()) if len(c) else math.nan
                row[f"{label}_mean_inliers_px"] = float(c[inliers].mean()) if inliers.any() else math.nan
                row[f"{label}_outliers"] = int((~inliers).sum())
                row["uncompensated_mean_px"] = float(u.mean()) if len(u) else math.nan
                row["detected"] = detected
                row["tracked"] = len(c)
            row["frame_pairs"] = len(result.residuals)
            table.append(row)
    finally:
        if world is not None:
            world.close()
    fig, ax = plt.subplots(figsize=(9, 3.6))
    x = np.arange(len(table))
    ax.bar(x - 0.2, [r["matrix_mean_px"] for r in table], 0.4, label="incl. outliers")
    ax.bar(
        x + 0.2,
        [r["matrix_mean_inliers_px"] for r in table],
        0.4,
        label=f"excl. outliers (> {config.outlier_px:g} px)",
    )
    ax.set_xticks(x, [r["case"] for r in table], rotation=30, ha="right", fontsize=8)
    ax.set_ylabel("mean |p2 - p2′| (px)")
    ax.set_title("Rotation compensation on pure rotations (Table 2)", fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    out_dir.mkdir(parents=True, exist_ok=True)
    fig.savefig(out_dir / "rotation.png", dpi=110)
    plt.close(fig)
    return {"table2": table, "rows": [], "figures": ["rotation.png"]}


def run_translation(config: TranslationConfig, out_dir: Path, progress: bool = True) -> dict[str, Any]:
    """Experiment 3 (Figs. 33, 35): x then y translation past each scene's capsules."""
    rows, panels, marks = [], [], {}
    for scene in config.scenes:
        path, turn = translation_path(config, scene)
        world = _world(path, config)
        try:
            result = run_playback(
                path,
                world,
                _settings(config),
                config.estimator,
                progress=progress,
                description=f"translation {scene.name}",
            )
        finally:
            world.close()
        rows += _metric_rows(scene.name, result, METHODS)
        for method in METHODS:
            marks[len(panels)] = turn - 0.5
            panels.append((f"{scene.name}: {method}", result.methods[method], result.references))
    figure = save_depth_figure(
        panels, out_dir / "translation.png", "x translation, then y translation (dashed: the turn)"
    )
    return {"rows": rows, "figures": [figure.name]}


def run_random6dof(config: Random6DofConfig, out_dir: Path, progress: bool = True) -> dict[str, Any]:
    """Experiment 4 (Fig. 38, Table 3): random 6-DoF path; depth errors and per-stage timings."""
    path = random_6dof_path(config)
    world = _world(path, config)
    try:
        result = run_playback(
            path, world, _settings(config), config.estimator, progress=progress, description="random6dof"
        )
    finally:
        world.close()
    figure = save_depth_figure(
        [(method, result.methods[method], result.references) for method in METHODS],
        out_dir / "random6dof.png",
        "Human-like random 6-DoF path in front of one capsule",
    )
    timings = []
    for method in METHODS:
        for stage, seconds in result.timings[method].items():
            values = np.asarray(seconds) * 1e3
            timings.append(
                {
                    "method": method,
                    "stage": stage,
                    "mean_ms": float(values.mean()),
                    "median_ms": float(np.median(values)),
                }
            )
    render = np.asarray(result.render_s) * 1e3
    timings.append(
        {
            "method": "-",
            "stage": "render (MuJoCo)",
            "mean_ms": float(render.mean()),
            "median_ms": float(np.median(render)),
        }
    )
    return {"rows": _metric_rows("random6dof", result, METHODS), "table3": timings, "figures": [figure.name]}


# The issue maps these five variables onto Appendices C–H as a group, not one by one, so no letter is given.
SWEEP_VARIABLES = (
    ("attitude_jitter_deg", "angular instability (deg per frame)"),
    ("distance_per_frame", "distance per frame (m)"),
    ("brightness", "brightness (1 = daylight)"),
    ("rotation_error", "rotation error (relative)"),
    ("translation_error", "translation error (relative)"),
)


def run_three_capsule(config: ThreeCapsuleConfig, out_dir: Path, progress: bool = True) -> dict[str, Any]:
    """Experiment 5 (Figs. 41–43, Appendices C–H): recorded flight, base run, one sweep per variable."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = record_three_capsule_flight(config)
    if config.obstacles:
        # An explicit capsule list in the config overrides the env layout's capsules for the playback.
        scene = scene_kwargs(config)
        path.obstacles, path.materials = scene["obstacles"], scene["materials"]
    save_path(path, out_dir / "three_capsule_path.npz")
    base = {
        "distance_per_frame": config.base.distance_per_frame,
        "brightness": config.base.brightness,
        "attitude_jitter_deg": config.base.attitude_jitter_deg,
        "rotation_error": config.base.rotation_error,
        "translation_error": config.base.translation_error,
        "max_frames": config.base.max_frames,
    }
    world = _world(path, config)
    rows, sweeps = [], []
    try:
        base_result = run_playback(
            path,
            world,
            _settings(config, **base),
            config.estimator,
            progress=progress,
            description="three base",
        )
        rows += _metric_rows("base", base_result, METHODS)
        for variable, _label in SWEEP_VARIABLES:
            for value in getattr(config.sweeps, variable):
                settings = {**base, variable: value}
                distance = settings["distance_per_frame"]
                if distance > path.arc_length()[-1]:
                    continue
                result = run_playback(
                    path,
                    world,
                    _settings(config, **settings),
                    config.estimator,
                    progress=progress,
                    description=f"{variable}={value:g}",
                )
                for row in _metric_rows(f"{variable}={value:g}", result, METHODS):
                    sweeps.append({"variable": variable, "value": value, **row})
    finally:
        world.close()
    base_figure = save_depth_figure(
        [(method, base_result.methods[method], base_result.references) for method in METHODS],
        out_dir / "three_capsule_base.png",
        f"Three capsules, base run ({config.base.distance_per_frame} m/frame)",
    )
    fig, axes = plt.subplots(
        2, len(SWEEP_VARIABLES), figsize=(3.4 * len(SWEEP_VARIABLES), 5.6), squeeze=False
    )
    for column, (variable, label) in enumerate(SWEEP_VARIABLES):
        for method, marker in zip(METHODS, ("o", "s"), strict=True):
            points = [r for r in sweeps if r["variable"] == variable and r["method"] == method]
            values = [r["value"] for r in points]
            axes[0, column].plot(
                values, [100 * r["median_rel_error"] for r in points], marker=marker, label=method
            )
            axes[1, column].plot(values, [r["valid_per_frame"] for r in points], marker=marker, label=method)
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
    fig.suptitle("Three capsules: one test variable changed from the base run (Appendices C–H)", fontsize=10)
    fig.tight_layout()
    fig.savefig(out_dir / "three_capsule_sweeps.png", dpi=110)
    plt.close(fig)
    return {
        "rows": rows,
        "sweeps": sweeps,
        "figures": [base_figure.name, "three_capsule_sweeps.png"],
        "recorded_frames": len(path),
        "recorded_length_m": float(path.arc_length()[-1]),
        "obstacles": path.obstacles.tolist(),
    }


@dataclass(frozen=True)
class Experiment:
    """An experiment: its config schema, runner and what the thesis showed."""

    name: str
    title: str
    schema: type
    runner: Callable[..., dict[str, Any]]
    thesis: str


EXPERIMENTS: dict[str, Experiment] = {
    e.name: e
    for e in (
        Experiment(
            "straight",
            "1. Straight flight toward one capsule (Figs. 22–24)",
            StraightConfig,
            run_straight,
            "Figs. 22–24 plot per-frame depths from x-flow, y-flow and bidirectional flow against the truth.",
        ),
        Experiment(
            "rotation",
            "2. Rotation compensation on pure rotations (Table 2)",
            RotationConfig,
            run_rotation,
            "Table 2 lists, for nine pure-rotation cases, the mean distance p1–p2′ including and excluding "
            "outliers (> 5 px) and the point counts.",
        ),
        Experiment(
            "translation",
            "3. x then y translation past one and four capsules (Figs. 33, 35)",
            TranslationConfig,
            run_translation,
            "Figs. 33 and 35 plot per-frame depths for x then y translation past one capsule and past four.",
        ),
        Experiment(
            "random6dof",
            "4. Human-like random 6-DoF path (Fig. 38) and performance (Table 3)",
            Random6DofConfig,
            run_random6dof,
            "Fig. 38 plots per-frame depths on a random 6-DoF path; Table 3 gives the estimator's run time.",
        ),
        Experiment(
            "three_capsule",
            "5. Three-capsule scene and its test variables (Figs. 41–43, Appendices C–H)",
            ThreeCapsuleConfig,
            run_three_capsule,
            "Figs. 41–43 and Appendices C–H plot per-frame depths in the three-capsule scene for the base run and "
            "for angular instability, distance per frame, brightness, rotation error and translation error.",
        ),
    )
}
