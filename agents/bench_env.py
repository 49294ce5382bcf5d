"""``flownav bench env``: steps per second of FlowNav-v0 per camera resolution, against a bare MuJoCo loop.

For the default config and each candidate resolution, one process steps ``gymnasium.make("FlowNav-v0")``
with a fixed scripted flight and, alternated with it, a bare loop on the same model: ``mujoco.mj_step`` ×
``env.substeps`` plus one render of the front camera per step, no controller, no estimator. The flight is the
same at every resolution (the camera does not act on the dynamics), so the estimator statistics (points per
frame, median depth error) compare like with like. Each env step is also split into its stages by timing
the env's own physics, renderer and estimator objects from outside (wrappers around their methods).
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from agents.bench import hardware_summary, markdown_table, quiet_gc, today, write_csv
from agents.machine import available_cores, gl_renderer, is_software_renderer

# The GL backend is read when mujoco is first imported; set it before anything below imports mujoco.
os.environ.setdefault("MUJOCO_GL", "egl")

DEFAULT_RESOLUTIONS = ((64, 48), (96, 72), (128, 96), (160, 120), (240, 180), (320, 240))
STAGES = ("physics", "render", "estimator", "ground_truth")
TARGET_RATIO = 1.5
# Criteria of the default-resolution choice. The env's own test spec asks for a median depth error <= 5 %;
# two valid points per histogram sector (median) keep most sectors of the observation from being empty.
MAX_DEPTH_ERROR_PCT = 5.0
MIN_VALID_PER_SECTOR = 2.0
TARGET_REAL_TIME_FACTOR = 20.0
# gym-pybullet-drones' reported real-time factor for one drone with 64×48 vision (their hardware, not ours).
PYBULLET_DRONES_RTF = 10.8
WARMUP_STEPS = 5


@dataclass
class _Subject:
    """One configuration under test: the env, its bare counterpart and the figures collected so far."""

    label: str
    kind: str  # "default", "resolution" or "fast_threshold": which comparison the row belongs to
    env: Any
    width: int
    height: int
    substeps: int
    frame_rate: float
    bare_data: Any
    bare_renderer: Any
    camera_id: int
    stage_seconds: dict[str, float] = field(default_factory=lambda: dict.fromkeys(STAGES, 0.0))
    env_blocks: list[float] = field(default_factory=list)  # seconds per step, one entry per block
    bare_blocks: list[float] = field(default_factory=list)
    stage_blocks: dict[str, list[float]] = field(default_factory=lambda: {s: [] for s in (*STAGES, "rest")})
    points_tracked: list[int] = field(default_factory=list)
    points_valid: list[int] = field(default_factory=list)
    depth_errors: list[float] = field(default_factory=list)
    steps_taken: int = 0
    episodes: int = 0


def _timed(function: Callable[..., Any], totals: dict[str, float], key: str) -> Callable[..., Any]:
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        start = time.perf_counter()
        try:
            return function(*args, **kwargs)
        finally:
            totals[key] += time.perf_counter() - start

    return wrapper


def _make_subject(label: str, kind: str, kwargs: dict[str, Any], seed: int) -> _Subject:
    import gymnasium as gym
    import mujoco

    import flownav_env  # noqa: F401  (registers FlowNav-v0)
    from flownav_env.rendering import CameraRenderer

    env = gym.make("FlowNav-v0", **kwargs)
    inner = env.unwrapped
    inner_physics = inner.physics
    subject = _Subject(
        label=label,
        kind=kind,
        env=env,
        width=inner.intrinsics.width,
        height=inner.intrinsics.height,
        substeps=inner.substeps,
        frame_rate=inner.frame_rate,
        bare_data=mujoco.MjData(inner_physics.model),
        # The env's own renderer class, so the bare loop draws exactly what the env draws.
        bare_renderer=CameraRenderer(inner_physics.model, inner.intrinsics.width, inner.intrinsics.height),
        camera_id=inner_physics.camera_id,
    )
    # Instance attributes shadow the methods: env.step calls these wrappers, which add ~1 µs per call.
    totals = subject.stage_seconds
    inner_physics.advance = _timed(inner_physics.advance, totals, "physics")
    inner_physics.ray_depths = _timed(inner_physics.ray_depths, totals, "ground_truth")
    inner._camera.render = _timed(inner._camera.render, totals, "render")
    inner.estimator.update = _timed(inner.estimator.update, totals, "estimator")
    env.reset(seed=seed)
    return subject


def _reset_bare(subject: _Subject) -> None:
    import mujoco

    inner = subject.env.unwrapped
    model, data = inner.physics.model, subject.bare_data
    # Obstacles are mocap bodies whose defaults the env wrote into the model, so a reset places them.
    mujoco.mj_resetData(model, data)
    data.qpos[:3] = (0.0, 0.0, inner.flight_height)
    data.qpos[3:7] = (1.0, 0.0, 0.0, 0.0)
    data.qvel[:3] = (inner.forward_speed, 0.0, 0.0)
    data.ctrl[:] = inner.physics.quad.mass * 9.81 / 4  # hover trim, held: there is no controller
    mujoco.mj_forward(model, data)


def _bare_block(subject: _Subject, steps: int) -> float:
    """Seconds per step of the bare loop over ``steps`` steps (reset before, not timed)."""
    import mujoco

    model = subject.env.unwrapped.physics.model
    data, renderer, camera, substeps = (
        subject.bare_data,
        subject.bare_renderer,
        subject.camera_id,
        subject.substeps,
    )
    _reset_bare(subject)
    start = time.perf_counter()
    for _ in range(steps):
        for _ in range(substeps):
            mujoco.mj_step(model, data)
        renderer.render(data, camera)
    return (time.perf_counter() - start) / steps


def _env_block(subject: _Subject, steps: int, seed: int, record: bool) -> float:
    """Seconds per env step over ``steps`` steps of the scripted flight; resets happen untimed."""
    from agents.bench_estimator import scripted_action

    env, totals = subject.env, subject.stage_seconds
    elapsed = 0.0
    stage_sums = dict.fromkeys((*STAGES, "rest"), 0.0)
    for _ in range(steps):
        action = scripted_action(subject.steps_taken).astype(np.float32)
        for key in totals:
            totals[key] = 0.0
        start = time.perf_counter()
        _, _, terminated, truncated, info = env.step(action)
        seconds = time.perf_counter() - start
        elapsed += seconds
        subject.steps_taken += 1
        for key in STAGES:
            stage_sums[key] += totals[key]
        stage_sums["rest"] += seconds - sum(totals[key] for key in STAGES)
        if record:
            subject.points_tracked.append(int(info["points_tracked"]))
            subject.points_valid.append(int(info["points_valid"]))
            if "depth_error_median" in info:
                subject.depth_errors.append(float(info["depth_error_median"]))
        if terminated or truncated:
            subject.episodes += 1
            subject.steps_taken = 0
            env.reset(seed=seed + subject.episodes)
    if record:
        for key, value in stage_sums.items():
            subject.stage_blocks[key].append(value / steps)
    return elapsed / steps


def measure_env(
    resolutions: Sequence[tuple[int, int]] = DEFAULT_RESOLUTIONS,
    steps: int = 100,
    repeats: int = 5,
    seed: int = 0,
    progress: bool = True,
    fast_thresholds: Sequence[int] = (),
) -> list[dict[str, Any]]:
    """Time FlowNav-v0 (default config, each resolution, each FAST threshold) against the bare MuJoCo loop.

    Args:
        resolutions: ``(width, height)`` candidates.
        steps: steps per timed block.
        repeats: timed blocks per configuration and side; env and bare alternate, their order swapping on
            every repeat, configurations visited forward and backward on alternate repeats.
        seed: seed of the first episode (later episodes use seed + 1, + 2, ...).
        progress: show a tqdm progress bar.
        fast_thresholds: FAST thresholds to compare at the default resolution (``estimator_kwargs``).

    Returns:
        One dict per configuration (the default first, then resolutions, then thresholds): steps/s, ratio, real-time factors, per-stage ms,
        median points per frame and median depth error.

    Raises:
        ValueError: ``steps`` or ``repeats`` < 1, or an empty ``resolutions``.
    """
    from tqdm import tqdm

    if steps < 1 or repeats < 1 or not resolutions:
        raise ValueError(
            f"need steps >= 1, repeats >= 1 and at least one resolution, got steps={steps}, "
            f"repeats={repeats}, resolutions={list(resolutions)}"
        )
    configs = [("FlowNav-v0 (default)", "default", {})]
    configs += [
        (f"{width}×{height}", "resolution", {"camera_width": width, "camera_height": height})
        for width, height in resolutions
    ]
    configs += [
        (f"FAST {threshold}", "fast_threshold", {"estimator_kwargs": {"fast_threshold": threshold}})
        for threshold in fast_thresholds
    ]
    subjects = [_make_subject(label, kind, kwargs, seed) for label, kind, kwargs in configs]
    try:
        for subject in subjects:  # warm-up: GL contexts, first-call allocations; not recorded
            _env_block(subject, WARMUP_STEPS, seed, record=False)
            _bare_block(subject, WARMUP_STEPS)
        bar = tqdm(total=repeats * len(subjects), desc="env blocks", disable=not progress)
        for repeat in range(repeats):
            order = subjects if repeat % 2 == 0 else subjects[::-1]
            for position, subject in enumerate(order):
                with quiet_gc():
                    if (repeat + position) % 2 == 0:
                        subject.env_blocks.append(_env_block(subject, steps, seed, record=True))
                        subject.bare_blocks.append(_bare_block(subject, steps))
                    else:
                        subject.bare_blocks.append(_bare_block(subject, steps))
                        subject.env_blocks.append(_env_block(subject, steps, seed, record=True))
                bar.update()
        bar.close()
        return [_summarise(subject) for subject in subjects]
    finally:
        for subject in subjects:
            subject.bare_renderer.close()
            subject.env.close()


def _summarise(subject: _Subject) -> dict[str, Any]:
    env_step = float(np.median(subject.env_blocks))
    bare_step = float(np.median(subject.bare_blocks))
    ratios = [env / bare for env, bare in zip(subject.env_blocks, subject.bare_blocks, strict=True)]
    row: dict[str, Any] = {
        "config": subject.label,
        "kind": subject.kind,
        "fast_threshold": subject.env.unwrapped.estimator.fast_threshold,
        "width": subject.width,
        "height": subject.height,
        "steps_per_s_env": 1.0 / env_step,
        "steps_per_s_bare": 1.0 / bare_step,
        "ratio_env_bare": float(np.median(ratios)),
        "ratio_min": min(ratios),
        "ratio_max": max(ratios),
        "real_time_factor_env": 1.0 / (env_step * subject.frame_rate),
        "real_time_factor_bare": 1.0 / (bare_step * subject.frame_rate),
        "ms_step": 1e3 * env_step,
    }
    for key, values in subject.stage_blocks.items():
        row[f"ms_{key}"] = 1e3 * float(np.median(values))
    row["points_tracked_median"] = float(np.median(subject.points_tracked))
    row["points_valid_median"] = float(np.median(subject.points_valid))
    row["depth_error_median_pct"] = (
        100 * float(np.median(subject.depth_errors)) if subject.depth_errors else math.nan
    )
    row["steps_with_depth_error"] = len(subject.depth_errors) / max(1, len(subject.points_valid))
    row["frame_rate"] = subject.frame_rate
    rows_, cols_ = subject.env.unwrapped.histogram_sectors
    row["histogram_sectors"] = rows_ * cols_
    row["substeps"] = subject.substeps
    return row


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
    _plot(rows[1:], plot_path)
    md_path.write_text(_report(rows, command, steps, repeats, elapsed))
    return [md_path, csv_path, plot_path]


def _plot(rows: list[dict[str, Any]], path: Path) -> None:
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


def _report(rows: list[dict[str, Any]], command: str, steps: int, repeats: int, elapsed: float) -> str:
    table = markdown_table(
        [
            "config",
            "FAST",
            "steps/s env",
            "steps/s bare",
            "env/bare",
            "real-time × env",
            "real-time × bare",
            "points tracked",
            "points valid",
            "depth err. %",
        ],
        [
            [
                row["config"],
                row["fast_threshold"],
                f"{row['steps_per_s_env']:.1f}",
                f"{row['steps_per_s_bare']:.1f}",
                f"{row['ratio_env_bare']:.2f} ({row['ratio_min']:.2f}–{row['ratio_max']:.2f})",
                f"{row['real_time_factor_env']:.1f}",
                f"{row['real_time_factor_bare']:.1f}",
                f"{row['points_tracked_median']:.0f}",
                f"{row['points_valid_median']:.0f}",
                f"{row['depth_error_median_pct']:.1f}",
            ]
            for row in rows
        ],
    )
    stage_table = markdown_table(
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
    default = rows[0]
    ratios = [row["ratio_env_bare"] for row in rows]
    renderer = gl_renderer()
    software = is_software_renderer(renderer)
    choice = _choice_text(rows, software)
    smallest = min(
        [row for row in rows if row["kind"] == "resolution"] or rows,
        key=lambda row: row["width"] * row["height"],
    )
    return f"""# Env performance: steps/s per camera resolution

Generated {today()} by

```
{command}
```

in {elapsed:.0f} s on the machine below. Absolute rates depend on it and on whatever else ran at the time, so the
env and the bare loop were alternated block by block in the same process, and the ratio is taken block by block
before the median over {repeats} blocks.

{hardware_summary(renderer)}

## Set-up
- Env: `gymnasium.make("FlowNav-v0", camera_width=W, camera_height=H)` (the default row: no kwargs), field
  layout, {default["frame_rate"]:.0f} frames/s, {default["substeps"]} physics substeps per step. A fixed
  scripted flight (`agents.bench_estimator.scripted_action`), identical at every resolution because the camera
  does not act on the dynamics; episodes end on collision/goal/time limit and restart with the next seed
  (resets not timed). Per block {steps} steps; steps/s = steps / summed step time, median over {repeats} blocks.
- Bare loop, same model and scene (`env.unwrapped.physics.model`, its own `MjData`): per step
  `mujoco.mj_step` × {default["substeps"]} + `Renderer.update_scene` + `render()` of the front camera at the
  same resolution; rotors held at hover thrust, no controller, no estimator, no ground truth.
- Real-time factor = simulated seconds per wall second = steps/s ÷ frame rate.
- Points tracked / valid: `info["points_tracked"]` / `info["points_valid"]`, median over all recorded steps;
  depth error: median over steps of `info["depth_error_median"]` (median relative error of the valid depths
  against the ray-cast truth; present on {100 * default["steps_with_depth_error"]:.0f} % of the steps).
- Stage split: the env's own objects timed from outside (wrappers around `physics.advance`, the camera
  renderer's `render`, `estimator.update` and `physics.ray_depths`); "rest" = the step minus those (sensor
  model and camera mount, relative motion, histogram, state, reward, Gymnasium wrappers).

## Steps per second and estimator output

{table}

## Where a step's time goes (median ms per step, share of the step)

{stage_table}

![time per stage and estimator output per resolution](env_performance.png)

## Default resolution

{choice}
{_threshold_text(rows)}
## Targets
- env/bare ≤ {TARGET_RATIO}: {min(ratios):.2f}–{max(ratios):.2f} over the configurations →
  **{"met" if max(ratios) <= TARGET_RATIO else "missed"}**{" (met for " + ", ".join(r["config"] for r in rows if r["ratio_env_bare"] <= TARGET_RATIO) + ")" if min(ratios) <= TARGET_RATIO < max(ratios) else ""}.
- Real-time factor ≥ {TARGET_REAL_TIME_FACTOR:.0f}×: default config {default["real_time_factor_env"]:.1f}× →
  **{"met" if default["real_time_factor_env"] >= TARGET_REAL_TIME_FACTOR else "missed"}**; the bare MuJoCo loop
  itself reaches {default["real_time_factor_bare"]:.1f}× here, so the ceiling is set by rendering, not by FlowNav.
- gym-pybullet-drones reports {PYBULLET_DRONES_RTF}× real time for one drone with 64×48 vision (on its authors'
  hardware, not measured here). FlowNav at {smallest["config"]}: {smallest["real_time_factor_env"]:.1f}×
  (bare loop {smallest["real_time_factor_bare"]:.1f}×) on {available_cores()} cores with {"software" if software else "hardware"} OpenGL; a like-for-like
  comparison needs both on the same machine.

Files: `env_performance.csv` (all columns, including the per-block min/max ratio), `env_performance.png`.
"""


def _choice_text(rows: list[dict[str, Any]], software_renderer: bool) -> str:
    """The default-resolution paragraph: each candidate against the current default, and the criteria."""
    default = rows[0]
    candidates = [row for row in rows if row["kind"] == "resolution"]
    same = [
        row for row in candidates if (row["width"], row["height"]) == (default["width"], default["height"])
    ]
    reference = same[0] if same else default
    min_valid = MIN_VALID_PER_SECTOR * default["histogram_sectors"]

    def meets(row: dict[str, Any]) -> bool:
        return (
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
    smallest = min(passing, key=lambda row: row["width"] * row["height"]) if passing else None
    verdict = (
        f"The smallest candidate meeting both is **{smallest['config']}**"
        if smallest is not None
        else "No candidate meets both"
    )
    cost_note = (
        "Rendering costs a large fixed time per frame here (software OpenGL), so larger frames are cheap in "
        "relative terms; on a GPU renderer the estimator's share, which grows with the point count, weighs more."
        if software_renderer
        else "Rendering is on a GPU here, so the estimator's share of a step, which grows with the point count, "
        "sets the cost of larger frames."
    )
    return f"""Criteria: median depth error ≤ {MAX_DEPTH_ERROR_PCT:.0f} % (the env's accuracy requirement) and a median of
at least {MIN_VALID_PER_SECTOR:.0f} valid points per histogram sector ({default["histogram_sectors"]} sectors →
{min_valid:.0f} points), at the highest steps/s. Current default: {default["width"]}×{default["height"]}.

{table}

{verdict}. {cost_note}"""


def _threshold_text(rows: list[dict[str, Any]]) -> str:
    """The FAST-threshold paragraph: each threshold against the default config, at the default resolution."""
    default = rows[0]
    thresholds = [row for row in rows if row["kind"] == "fast_threshold"]
    if not thresholds:
        return ""
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
    return f"""
## FAST threshold

At the default resolution, against the default config (FAST threshold {default["fast_threshold"]}, the env's
`ENV_ESTIMATOR_DEFAULTS`). All these rows render the same frames, so their bare loops are the same work:
"steps/s vs default" is the default's env/bare ratio over the row's, each ratio taken block by block against
a bare loop run next to it, which cancels most of the load from other jobs on the machine.

{table}
"""
