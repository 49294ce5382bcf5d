"""One episode, the one place an agent flies: ``reset(seed)``, ``predict``/``step`` to the end, one record."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np

from agents.analysis.episode_record import EpisodeRecord
from agents.evaluation.plausibility import implausibility
from agents.policies import Agent, predict_location

__all__ = ["EpisodeRecord", "run_episode"]


def _env_name(env: gym.Env[dict[str, np.ndarray], np.ndarray], factor: str, level: float) -> str:
    """The env id with what the episode was flown as (a suite tier, or a sweep factor at its level)."""
    env_id = env.spec.id if env.spec is not None else type(env.unwrapped).__name__
    return f"{env_id} ({factor}{f' {level:g}' if level else ''})"


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
    position = info["position"]
    path_length, total_return, steps, widest, fastest = 0.0, 0.0, 0, 0.0, 0.0
    valid_points, depth_errors, outlier_shares = [], [], []
    terminated = truncated = False
    # As SB3's evaluate_policy: an agent with memory gets its state back and is told where an episode starts.
    agent_state, episode_start = None, np.ones(1, bool)
    episode = f"agent {label or type(agent).__name__!r} on {_env_name(env, factor, level)}, layout {seed}"
    while not (terminated or truncated):
        # An outside agent's errors in predict say where they happened themselves (agents.policies.agent_process).
        action, agent_state = agent.predict(
            observation, state=agent_state, episode_start=episode_start, deterministic=True
        )
        episode_start = np.zeros(1, bool)
        try:
            observation, reward, terminated, truncated, info = env.step(action)
        except ValueError as error:
            # The env refuses the action (NaN, infinite, a wrong shape): the agent's, said with where it is.
            location = predict_location(agent)
            raise ValueError(
                f"{episode}, step {steps + 1}: {error}"
                + (f"; the action came from predict at {location}" if location else "")
            ) from error
        steps += 1
        total_return += float(reward)
        new_position = info["position"]
        step_length = float(np.linalg.norm(new_position - position))
        path_length += step_length
        fastest = max(fastest, step_length)
        position = new_position
        widest = max(widest, abs(float(position[1])))
        valid_points.append(info["points_valid"])
        if "depth_error_median" in info:
            depth_errors.append(info["depth_error_median"])
            outlier_shares.append(info["depth_outlier_share"])
    check_own_progress(env, info, episode)
    frame_rate = env.get_wrapper_attr("frame_rate")
    record = EpisodeRecord(
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
    problem = implausibility(record, env.get_wrapper_attr("settings"), fastest)
    if problem:
        raise ValueError(
            f"{episode}: not a flight the physics allows ({problem}); nothing was recorded of it"
        )
    return record


# How far short of the goal line (m) a success's final position may lie: none, but for rounding.
GOAL_TOLERANCE_M = 1e-6


def check_own_progress(
    env: gym.Env[dict[str, np.ndarray], np.ndarray], info: dict[str, object], episode: str
) -> None:
    """A success needs the drone's own progress to the goal line: on a field course the line stands at the
    course's ``field_length`` from the start, read from the settings the episode was made with, not from the
    task's state that an agent in this process could reach.

    Raises:
        ValueError: one line naming the episode: a success short of the goal line; nothing is recorded of it.
    """
    settings = env.get_wrapper_attr("settings")
    if not info["success"] or settings.layout != "field":
        return
    reached = float(info["progress"])  # type: ignore[arg-type]
    if reached < settings.field_length - GOAL_TOLERANCE_M:
        raise ValueError(
            f"{episode}: a success at x = {reached:.2f} m, short of the goal line at {settings.field_length:.2f} m; "
            "a success needs the drone's own progress to the line, so nothing was recorded of that episode"
        )
