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

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from agents.studies.thesis.camera_paths import random_6dof_path, straight_path, translation_path
from agents.studies.thesis.experiment_configs import (
    ExperimentConfig,
    Random6DofConfig,
    RotationConfig,
    StraightConfig,
    ThreeCapsuleConfig,
    TranslationConfig,
)
from agents.studies.thesis.figures import save_depth_figure
from agents.studies.thesis.metrics import METHODS, FrameRow, MetricRow, metric_rows
from agents.studies.thesis.playback_runs import RunResult, run_playback
from agents.studies.thesis.results import ExperimentResult, TimingRow
from agents.studies.thesis.rotation import run_rotation
from agents.studies.thesis.three_capsule import SWEEP_VARIABLES, run_three_capsule
from estimator import CameraIntrinsics, FlowDepthEstimator
from flownav_env.playback import CameraPath, PlaybackSettings, PlaybackWorld

__all__ = ["EXPERIMENTS", "SWEEP_VARIABLES", "Experiment"]


def _play(
    path: CameraPath, config: ExperimentConfig, label: str, progress: bool, component_variants: bool = False
) -> RunResult:
    """One playback of ``path`` through both estimators (``label`` its progress bar's; ``progress`` and
    ``component_variants`` as :func:`run_playback`'s), in a world of its own closed afterwards."""
    world = PlaybackWorld(path, config.camera.width, config.camera.height, config.camera.fov_deg)
    try:
        settings = PlaybackSettings(seed=config.seed)
        return run_playback(
            path,
            world,
            settings,
            config.estimator,
            component_variants=component_variants,
            progress=progress,
            description=label,
        )
    finally:
        world.close()


def run_straight(config: StraightConfig, out_dir: Path, progress: bool = True) -> ExperimentResult:
    """Experiment 1 (Figs. 22–24): straight flight toward one capsule; four depth variants."""
    result = _play(straight_path(config), config, "straight", progress=progress, component_variants=True)
    titles = {
        "x-flow": "x-flow only (Fig. 22)",
        "y-flow": "y-flow only (Fig. 23)",
        "thesis": "bidirectional, larger component (thesis method, Fig. 24)",
        "triangulation": "triangulation (both components, least squares)",
    }
    figure = save_depth_figure(
        [(title, result.methods[name], result.references) for name, title in titles.items()],
        out_dir / "straight.png",
        f"Straight flight toward one capsule, {config.distance_per_frame} m/frame",
    )
    return {"rows": metric_rows("straight", result.methods, titles), "figures": [figure.name]}


def run_translation(config: TranslationConfig, out_dir: Path, progress: bool = True) -> ExperimentResult:
    """Experiment 3 (Figs. 33, 35): x then y translation past each scene's capsules."""
    rows: list[MetricRow] = []
    panels: list[tuple[str, list[FrameRow], np.ndarray]] = []
    marks: dict[int, float] = {}
    for scene in config.scenes:
        path, turn = translation_path(config, scene)
        result = _play(path, config, f"translation {scene.name}", progress=progress)
        rows += metric_rows(scene.name, result.methods, METHODS)
        for method in METHODS:
            marks[len(panels)] = turn - 0.5
            panels.append((f"{scene.name}: {method}", result.methods[method], result.references))
    title = "x translation, then y translation (dashed: the turn)"
    figure = save_depth_figure(panels, out_dir / "translation.png", title, marks=marks)
    return {"rows": rows, "figures": [figure.name]}


def run_random6dof(config: Random6DofConfig, out_dir: Path, progress: bool = True) -> ExperimentResult:
    """Experiment 4 (Fig. 38, Table 3): random 6-DoF path; depth errors and per-stage timings."""
    result = _play(random_6dof_path(config), config, "random6dof", progress=progress)
    figure = save_depth_figure(
        [(method, result.methods[method], result.references) for method in METHODS],
        out_dir / "random6dof.png",
        "Human-like random 6-DoF path in front of one capsule",
    )
    timings = [
        _timing_row(method, stage, seconds)
        for method in METHODS
        for stage, seconds in result.timings[method].items()
    ]
    timings.append(_timing_row("-", "render (MuJoCo)", result.render_s))
    intrinsics = CameraIntrinsics.from_fov(config.camera.width, config.camera.height, config.camera.fov_deg)
    return {
        "rows": metric_rows("random6dof", result.methods, METHODS),
        "table3": timings,
        "figures": [figure.name],
        "fast_threshold": FlowDepthEstimator(intrinsics, **config.estimator).fast_threshold,
    }


def _timing_row(method: str, stage: str, seconds: list[float]) -> TimingRow:
    milliseconds = np.asarray(seconds) * 1e3
    mean, median = float(milliseconds.mean()), float(np.median(milliseconds))
    return {"method": method, "stage": stage, "mean_ms": mean, "median_ms": median}


@dataclass(frozen=True)
class Experiment:
    """An experiment: its config schema and runner (``templates/thesis_readme.md.j2`` states what the thesis
    showed)."""

    name: str
    title: str
    schema: type[ExperimentConfig]
    runner: Callable[..., ExperimentResult]


EXPERIMENTS: dict[str, Experiment] = {
    name: Experiment(name, title, schema, runner)
    for name, title, schema, runner in (
        ("straight", "1. Straight flight toward one capsule (Figs. 22–24)", StraightConfig, run_straight),
        ("rotation", "2. Rotation compensation on pure rotations (Table 2)", RotationConfig, run_rotation),
        (
            "translation",
            "3. x then y translation past one and four capsules (Figs. 33, 35)",
            TranslationConfig,
            run_translation,
        ),
        (
            "random6dof",
            "4. Human-like random 6-DoF path (Fig. 38) and performance (Table 3)",
            Random6DofConfig,
            run_random6dof,
        ),
        (
            "three_capsule",
            "5. Three-capsule scene and its test variables (Figs. 41–43, Appendices C–H)",
            ThreeCapsuleConfig,
            run_three_capsule,
        ),
    )
}
