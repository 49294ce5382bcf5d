"""Recording a camera path from a flight of the Gymnasium env (the thesis's record mode, §3.4)."""

from __future__ import annotations

from collections.abc import Callable

import gymnasium as gym
import numpy as np

from flownav_env.env import FlowNavEnv, Observation
from flownav_env.playback.path import CameraPath, path_from_poses


def record_env_flight(
    env: gym.Env,
    policy: Callable[[Observation, int], np.ndarray],
    steps: int,
    seed: int | None = None,
    texture_seed: int = 0,
) -> CameraPath:
    """Fly :class:`flownav_env.FlowNavEnv` with ``policy`` and record the forward camera's path.

    Args:
        env: A FlowNavEnv (or a wrapper of one).
        policy: ``policy(observation, step) -> action``.
        steps: Most steps to fly, an integer >= 1; the recording stops early when the episode ends.
        seed: Seed of ``env.reset``.
        texture_seed: The env's ``texture_seed`` (the env does not keep it), stored with the path so that
            playback shows the same world.

    Returns:
        The camera path (reset frame plus one frame per step) with the episode's obstacles and materials.

    Raises:
        ValueError: ``env`` is not a FlowNavEnv or a wrapper of one, ``steps`` is not a positive integer, or
            the episode ended before a second frame.
    """
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 1:
        raise ValueError(f"steps must be an integer >= 1, got {steps!r}")
    base = env.unwrapped
    if not isinstance(base, FlowNavEnv):
        raise ValueError(f"env must be a FlowNavEnv or a wrapper of one, got {type(base).__name__}")
    observation, _ = env.reset(seed=seed)
    rotations, positions = [], []

    def record() -> None:
        rotation, position = base.physics.camera_pose()
        rotations.append(rotation)
        positions.append(position)

    record()
    for step in range(int(steps)):
        observation, _, terminated, truncated, _ = env.step(policy(observation, step))
        record()
        if terminated or truncated:
            break
    physics = base.physics
    obstacle_count = len(physics.obstacle_positions)
    geom_materials = physics.model.geom_matid[physics.obstacle_geoms[:obstacle_count]]
    materials = np.array(
        [int(np.flatnonzero(physics.material_ids == m)[0]) for m in geom_materials], np.int64
    )
    return path_from_poses(
        np.asarray(rotations),
        np.asarray(positions),
        base.frame_rate,
        obstacles=physics.obstacle_positions.copy(),
        materials=materials,
        texture_seed=int(texture_seed),
        obstacle_radius=base.layout_params.obstacle_radius,
        obstacle_height=base.layout_params.obstacle_height,
    )
