"""One episode on video: the camera view with tracked points, flow vectors and depth-coloured circles beside a
chase view (the env's ``rgb_array`` render), encoded by imageio's ffmpeg plugin (``imageio-ffmpeg`` is a
declared dependency; gymnasium's ``RecordVideo`` is not used, since it needs moviepy, which is not)."""

from __future__ import annotations

from pathlib import Path
from typing import cast

import gymnasium as gym
import imageio.v2 as imageio
import numpy as np
from imageio.core.format import Format

import flownav_env  # noqa: F401  (registers the env ids)
from agents.policies import agent_env_kwargs, load_agent


def record_episode(
    agent_name: str,
    env_id: str,
    seed: int,
    out: Path,
    *,
    policy: str | None = None,
    max_steps: int = 600,
    trust_pickle: bool = False,
) -> dict:
    """Fly one episode with rendering on and write it to ``out``; returns the last step's info.

    Args:
        agent_name: the agent (a learned one named alone flies its first shipped training seed: one episode).
        env_id: the env id; a learned agent adds the env settings of the config beside its zip.
        seed: the layout seed.
        out: the mp4 to write.
        policy: a learned agent's ``.zip`` instead of the shipped one.
        max_steps: steps at most.
        trust_pickle: load a ``policy`` without a training config beside it by unpickling it (runs its code).

    Raises:
        ValueError: ``max_steps`` < 1, a bad policy file, or an env lacking an observation key the agent reads.
        FileNotFoundError: a missing policy file.
    """
    if max_steps < 1:
        raise ValueError(f"max_steps must be >= 1, got {max_steps}")
    agent = load_agent(agent_name, policy, trust_pickle=trust_pickle)
    env = gym.make(env_id, render_mode="rgb_array", **agent_env_kwargs(agent_name, policy))
    try:
        observation, info = env.reset(seed=seed)
        fps = env.metadata.get("render_fps", 10)
        # The first action before the writer opens: an agent that cannot fly this env leaves no empty mp4.
        action, state = agent.predict(observation, episode_start=np.ones(1, bool), deterministic=True)
        out.parent.mkdir(parents=True, exist_ok=True)
        with imageio.get_writer(out, fps=fps, codec="libx264", quality=7, macro_block_size=16) as opened:
            # imageio's v2 stubs type it as a base that lacks append_data
            writer = cast(Format.Writer, opened)
            for step in range(1, max_steps + 1):
                observation, _, terminated, truncated, info = env.step(action)
                writer.append_data(np.asarray(env.render()))
                if terminated or truncated or step == max_steps:
                    break
                # The state carries a recurrent or frame-stacked policy's memory from step to step.
                action, state = agent.predict(
                    observation, state=state, episode_start=np.zeros(1, bool), deterministic=True
                )
    finally:
        env.close()
    return info
