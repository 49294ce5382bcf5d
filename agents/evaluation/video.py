"""One episode on video: the camera view with tracked points, flow vectors and depth-coloured circles beside a
chase view (the env's ``rgb_array`` render), encoded by imageio's ffmpeg plugin (``imageio-ffmpeg`` is a
declared dependency; gymnasium's ``RecordVideo`` is not used, since it needs moviepy, which is not)."""

from __future__ import annotations

from pathlib import Path

from agents.policies import agent_env_kwargs, load_agent


def record_episode(
    agent_name: str, env_id: str, seed: int, out: Path, *, policy: str | None = None, max_steps: int = 600
) -> dict:
    """Fly one episode with rendering on and write it to ``out``; returns the last step's info."""
    import gymnasium as gym
    import imageio.v2 as imageio

    import flownav_env  # noqa: F401

    if max_steps < 1:
        raise ValueError(f"max_steps must be >= 1, got {max_steps}")
    agent = load_agent(agent_name, policy)
    env = gym.make(env_id, render_mode="rgb_array", **agent_env_kwargs(agent_name, policy))
    out.parent.mkdir(parents=True, exist_ok=True)
    observation, info = env.reset(seed=seed)
    fps = env.metadata.get("render_fps", 10)
    with imageio.get_writer(out, fps=fps, codec="libx264", quality=7, macro_block_size=16) as writer:
        for _ in range(max_steps):
            action, _ = agent.predict(observation, deterministic=True)
            observation, _, terminated, truncated, info = env.step(action)
            writer.append_data(env.render())
            if terminated or truncated:
                break
    env.close()
    return info
