"""``flownav bench env``: steps per second of FlowNav-v0 per camera resolution, against a bare MuJoCo loop.

For the default config and each candidate resolution, one process steps ``gymnasium.make("FlowNav-v0")``
with a fixed scripted flight and, alternated with it, a bare loop on the same model: ``mujoco.mj_step`` ×
``env.substeps`` plus one render of the front camera per step, no controller, no estimator. The flight is the
same at every resolution (the camera does not act on the dynamics), so the estimator statistics (points per
frame, median depth error) compare like with like. Each env step is also split into its stages by the env's
own stage timing (:meth:`flownav_env.FlowNavEnv.time_stages`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import flownav_env  # first: it picks the GL backend (MUJOCO_GL) before mujoco's first import below

# isort: split
import cv2
import gymnasium as gym
import mujoco
import numpy as np
from tqdm import tqdm

from agents.studies.perf.flight import fast_lk, scripted_action
from agents.studies.perf.report_kit import interval, median, quiet_gc
from flownav_env.rendering import CameraRenderer
from flownav_env.stage_timing import STAGES, StageTimes

DEFAULT_RESOLUTIONS = ((64, 48), (96, 72), (128, 96), (160, 120), (240, 180), (320, 240))
TARGET_RATIO = (
    1.3  # the throughput target: env step at most 1.3x the bare render + physics loop of the same scene
)
# The time-to-policy target re-set it on the floor loop (bare + the OpenCV work any FAST + LK estimator does).
TARGET_FLOOR_RATIO = 1.3
TARGET_REAL_TIME_FACTOR = 20.0
# gym-pybullet-drones' reported real-time factor for one drone with 64×48 vision (their hardware, not ours).
PYBULLET_DRONES_RTF = 10.8
PYBULLET_DRONES_VISION = (64, 48)
WARMUP_STEPS = 5


@dataclass
class _Subject:
    """One configuration under test: the env, its bare counterpart and the figures collected so far."""

    label: str
    env: gym.Env[Any, Any]
    inner: flownav_env.FlowNavEnv
    bare_data: mujoco.MjData
    bare_renderer: CameraRenderer
    stage_times: StageTimes
    env_blocks: list[float] = field(default_factory=list)  # seconds per step, one entry per block
    bare_blocks: list[float] = field(default_factory=list)
    floor_blocks: list[float] = field(default_factory=list)
    stage_blocks: dict[str, list[float]] = field(default_factory=lambda: {s: [] for s in (*STAGES, "rest")})
    points_tracked: list[int] = field(default_factory=list)
    points_valid: list[int] = field(default_factory=list)
    depth_errors: list[float] = field(default_factory=list)
    steps_taken: int = 0
    episodes: int = 0


def _make_subject(label: str, kwargs: dict[str, Any], seed: int) -> _Subject:
    env = gym.make("FlowNav-v0", **kwargs)
    inner = env.unwrapped
    if not isinstance(inner, flownav_env.FlowNavEnv):
        raise TypeError(f"FlowNav-v0 made a {type(inner).__name__}, not a FlowNavEnv")
    model, size = inner.physics.model, (inner.intrinsics.width, inner.intrinsics.height)
    subject = _Subject(
        label=label,
        env=env,
        inner=inner,
        bare_data=mujoco.MjData(model),
        # The env's own renderer class, so the bare loop draws exactly what the env draws.
        bare_renderer=CameraRenderer(model, *size, onboard=True),
        stage_times=inner.time_stages(),
    )
    env.reset(seed=seed)
    return subject


def _bare_block(subject: _Subject, steps: int, on_frame: Callable[[np.ndarray], None] | None = None) -> float:
    """Seconds per step of the bare loop over ``steps`` steps (reset before, not timed); ``on_frame`` is timed
    work done on each rendered frame (the floor loop's OpenCV work)."""
    inner, data = subject.inner, subject.bare_data
    model, camera, substeps = inner.physics.model, inner.physics.camera_id, inner.substeps
    # Obstacles are mocap bodies whose defaults the env wrote into the model, so a reset places them.
    mujoco.mj_resetData(model, data)
    data.qpos[:3] = (0.0, 0.0, inner.settings.flight_height)
    data.qpos[3:7] = (1.0, 0.0, 0.0, 0.0)
    data.qvel[:3] = (inner.forward_speed, 0.0, 0.0)
    data.ctrl[:] = inner.physics.quad.mass * 9.81 / 4  # hover trim, held: there is no controller
    mujoco.mj_forward(model, data)
    start = time.perf_counter()
    for _ in range(steps):
        for _ in range(substeps):
            mujoco.mj_step(model, data)
        frame = subject.bare_renderer.render(data, camera)
        if on_frame is not None:
            on_frame(frame)
    return (time.perf_counter() - start) / steps


def _floor_block(subject: _Subject, steps: int) -> float:
    """Seconds per step of the bare loop plus the bare OpenCV work any flow estimator of these settings must
    do on each frame: grayscale, FAST on the previous frame, one pyramidal LK pass into the current one.

    Nothing of FlowNav's own runs (no controller, checks, backward pass, depth stage, histogram), so the ratio
    of this loop to the bare one is the least an env that runs the thesis's estimator can reach.
    """
    estimator = subject.inner.estimator
    detector = cv2.FastFeatureDetector.create(estimator.fast_threshold, True)
    previous: list[np.ndarray] = []

    def track(frame: np.ndarray) -> None:
        gray = cv2.cvtColor(frame, cv2.COLOR_RGB2GRAY)
        if previous:
            fast_lk(
                detector, previous[0], gray, estimator.win_size, estimator.max_level, estimator.max_points
            )
        previous[:] = [gray]

    return _bare_block(subject, steps, on_frame=track)


def _env_block(subject: _Subject, steps: int, seed: int, record: bool) -> float:
    """Seconds per env step over ``steps`` steps of the scripted flight; resets happen untimed."""
    env, times = subject.env, subject.stage_times
    elapsed = 0.0
    stage_sums = dict.fromkeys((*STAGES, "rest"), 0.0)
    for _ in range(steps):
        action = scripted_action(subject.steps_taken).astype(np.float32)
        before = times.snapshot()
        start = time.perf_counter()
        _, _, terminated, truncated, info = env.step(action)
        seconds = time.perf_counter() - start
        after = times.snapshot()
        elapsed += seconds
        subject.steps_taken += 1
        for key in STAGES:
            stage_sums[key] += after[key] - before[key]
        stage_sums["rest"] += seconds - sum(after[key] - before[key] for key in STAGES)
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
) -> list[dict[str, float | str]]:
    """Time FlowNav-v0 (default config, each resolution) against the bare MuJoCo loop.

    Args:
        resolutions: ``(width, height)`` candidates.
        steps: steps per timed block.
        repeats: timed blocks per configuration and side; env and bare alternate, their order swapping on
            every repeat, configurations visited forward and backward on alternate repeats.
        seed: seed of the first episode (later episodes use seed + 1, + 2, ...).
        progress: show a tqdm progress bar.

    Returns:
        One dict per configuration (the default first, then the resolutions): steps/s, ratios,
        real-time factors, per-stage ms, median points per frame and median depth error.

    Raises:
        ValueError: ``steps`` or ``repeats`` < 1, or an empty ``resolutions``.
    """
    if steps < 1 or repeats < 1 or not resolutions:
        raise ValueError(
            f"need steps >= 1, repeats >= 1 and at least one resolution, got steps={steps}, "
            f"repeats={repeats}, resolutions={list(resolutions)}"
        )
    configs: list[tuple[str, dict[str, Any]]] = [("FlowNav-v0 (default)", {})]
    configs += [
        (f"{width}×{height}", {"camera_width": width, "camera_height": height})
        for width, height in resolutions
    ]
    subjects = [_make_subject(label, kwargs, seed) for label, kwargs in configs]
    try:
        for subject in subjects:  # warm-up: GL contexts, first-call allocations; not recorded
            _env_block(subject, WARMUP_STEPS, seed, record=False)
            _bare_block(subject, WARMUP_STEPS)
            _floor_block(subject, WARMUP_STEPS)
        bar = tqdm(total=repeats * len(subjects), desc="env blocks", disable=not progress)
        for repeat in range(repeats):
            order = subjects if repeat % 2 == 0 else subjects[::-1]
            for position, subject in enumerate(order):
                with quiet_gc():
                    if (repeat + position) % 2 == 0:
                        subject.env_blocks.append(_env_block(subject, steps, seed, record=True))
                        subject.bare_blocks.append(_bare_block(subject, steps))
                        subject.floor_blocks.append(_floor_block(subject, steps))
                    else:
                        subject.floor_blocks.append(_floor_block(subject, steps))
                        subject.bare_blocks.append(_bare_block(subject, steps))
                        subject.env_blocks.append(_env_block(subject, steps, seed, record=True))
                bar.update()
        bar.close()
        return [_summarise(subject) for subject in subjects]
    finally:
        for subject in subjects:
            subject.bare_renderer.close()
            subject.env.close()


def _summarise(subject: _Subject) -> dict[str, float | str]:
    inner = subject.inner
    env_step, bare_step = median(subject.env_blocks), median(subject.bare_blocks)
    sides = {"env": subject.env_blocks, "bare": subject.bare_blocks, "floor": subject.floor_blocks}
    row: dict[str, float | str] = {
        "config": subject.label,
        "fast_threshold": inner.estimator.fast_threshold,
        "width": inner.intrinsics.width,
        "height": inner.intrinsics.height,
        "steps_per_s_env": 1.0 / env_step,
        "steps_per_s_bare": 1.0 / bare_step,
    }
    # Each ratio block by block, its median and range (column names as in the committed CSVs).
    for name, prefix, top, bottom in (
        ("ratio_env_bare", "ratio", "env", "bare"),
        ("ratio_floor_bare", "ratio_floor", "floor", "bare"),
        ("ratio_env_floor", "ratio_env_floor", "env", "floor"),
    ):
        row |= interval(name, [a / b for a, b in zip(sides[top], sides[bottom], strict=True)], prefix)
    row |= {
        "ms_floor": 1e3 * median(subject.floor_blocks),
        "ms_bare": 1e3 * bare_step,
        "real_time_factor_env": 1.0 / (env_step * inner.frame_rate),
        "real_time_factor_bare": 1.0 / (bare_step * inner.frame_rate),
        "ms_step": 1e3 * env_step,
    }
    row |= {f"ms_{key}": 1e3 * median(values) for key, values in subject.stage_blocks.items()}
    return row | {
        "points_tracked_median": median(subject.points_tracked),
        "points_valid_median": median(subject.points_valid),
        "depth_error_median_pct": 100 * median(subject.depth_errors),
        "steps_with_depth_error": len(subject.depth_errors) / max(1, len(subject.points_valid)),
        "frame_rate": inner.frame_rate,
        "substeps": inner.substeps,
    }
