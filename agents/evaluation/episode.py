"""One episode, the one place an agent flies: ``reset(seed)``, ``predict``/``step`` to the end, one record."""

from __future__ import annotations

import math
from dataclasses import dataclass

import gymnasium as gym
import numpy as np

from agents.policies import Agent


@dataclass
class EpisodeRecord:
    """What one episode came to, and what defined it; one CSV row.

    The identity fields (``env_id`` to ``code_version``) are filled in by the runner from the task that flew
    the episode, so that a resumed run can tell an episode flown with other settings from its own.
    ``env_kwargs`` and ``agent_params`` are canonical JSON (``agent_params``: every parameter of a reactive
    agent, defaults included, :func:`~agents.policies.agent_parameters`); ``policy_sha256`` is the learned policy file's
    content hash ("" for reactive agents). ``code_version`` is recorded for provenance only: resuming does not
    compare it, or every commit would fly every episode again.

    Depth quality, over the steps with ground truth: ``median_depth_error`` is the median of the per-step
    median relative errors, ``mean_depth_outlier_share`` the mean per-step share of valid depths off by more
    than half (``estimator.accuracy.OUTLIER_RELATIVE_ERROR``); NaN when no step had ground truth, or (the
    outlier share) in files written before it was recorded.
    """

    agent: str
    factor: str
    level: float
    seed: int
    collision: bool
    success: bool
    out_of_bounds: bool
    truncated: bool
    progress_m: float
    time_s: float
    steps: int
    min_clearance_m: float
    path_length_m: float
    mean_points_valid: float
    median_depth_error: float
    episode_return: float
    env_id: str = ""
    env_kwargs: str = ""
    agent_params: str = ""
    policy_sha256: str = ""
    code_version: str = ""
    # Last, and defaulted: files written before them keep their columns (records.EARLIER_CSV_FIELDS).
    mean_depth_outlier_share: float = math.nan
    # The benchmark suite's version (flownav_env.tiers.SUITE_VERSION) for episodes of the suite, else "".
    suite_version: str = ""
    # The farthest the drone went sideways of the course axis (m): whether it left the capsule field for the
    # free lane beside it (agents/evaluation/lane.py); NaN in files written before it was recorded.
    max_abs_lateral_m: float = math.nan


def run_episode(
    env: gym.Env[dict[str, np.ndarray], np.ndarray],
    agent: Agent,
    seed: int,
    *,
    label: str = "",
    factor: str = "clean",
    level: float = 0.0,
) -> EpisodeRecord:
    """Fly one episode of ``env`` with ``agent`` from ``reset(seed=seed)`` to termination or truncation."""
    observation, info = env.reset(seed=seed)
    position = np.array([0.0, 0.0, 0.0])
    path_length, total_return, steps, widest = 0.0, 0.0, 0, 0.0
    valid_points, depth_errors, outlier_shares = [], [], []
    terminated = truncated = False
    # As SB3's evaluate_policy: an agent with memory gets its state back and is told where an episode starts.
    agent_state, episode_start = None, np.ones(1, bool)
    while not (terminated or truncated):
        action, agent_state = agent.predict(
            observation, state=agent_state, episode_start=episode_start, deterministic=True
        )
        episode_start = np.zeros(1, bool)
        observation, reward, terminated, truncated, info = env.step(action)
        steps += 1
        total_return += float(reward)
        new_position = info["position"]
        if steps > 1:
            path_length += float(np.linalg.norm(new_position - position))
        position = new_position
        widest = max(widest, abs(float(position[1])))
        valid_points.append(info["points_valid"])
        if "depth_error_median" in info:
            depth_errors.append(info["depth_error_median"])
            outlier_shares.append(info["depth_outlier_share"])
    frame_rate = env.get_wrapper_attr("frame_rate")
    return EpisodeRecord(
        agent=label,
        factor=factor,
        level=float(level),
        seed=int(seed),
        collision=bool(info["collision"]),
        success=bool(info["success"]),
        out_of_bounds=bool(info.get("out_of_bounds", False)),
        truncated=bool(truncated and not terminated),
        progress_m=float(info["progress"]),
        time_s=steps / frame_rate,
        steps=steps,
        min_clearance_m=float(info["min_clearance"]),
        path_length_m=path_length,
        mean_points_valid=float(np.mean(valid_points)) if valid_points else 0.0,
        median_depth_error=float(np.median(depth_errors)) if depth_errors else math.nan,
        episode_return=float(total_return),
        mean_depth_outlier_share=float(np.mean(outlier_shares)) if outlier_shares else math.nan,
        max_abs_lateral_m=widest,
    )
