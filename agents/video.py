"""Writes an mp4 of one episode: the camera view with tracked points, flow vectors and depth-coloured circles
beside a chase view (the env's ``rgb_array`` render), encoded by imageio's ffmpeg plugin."""

from __future__ import annotations

import argparse
from pathlib import Path

from agents.evaluation import EVAL_SEED_START

HELP = "record an mp4 of an agent's episode with the flow overlay"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from agents.policies import AGENT_NAMES

    parser.add_argument("--agent", required=True, choices=AGENT_NAMES)
    parser.add_argument("--policy", help="PPO policy .zip (default results/policies/<agent>.zip)")
    parser.add_argument("--env-id", default="FlowNav-v0")
    parser.add_argument("--seed", type=int, default=EVAL_SEED_START)
    parser.add_argument("--out", help="mp4 path (default results/videos/<agent>_<env-id>_<seed>.mp4)")
    parser.add_argument("--max-steps", type=int, default=600)


def record_episode(
    agent_name: str, env_id: str, seed: int, out: Path, *, policy: str | None = None, max_steps: int = 600
) -> dict:
    """Fly one episode with rendering on and write it to ``out``; returns the last step's info."""
    import gymnasium as gym
    import imageio.v2 as imageio

    import flownav_env  # noqa: F401
    from agents.policies import agent_env_kwargs, load_agent

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


def run(args: argparse.Namespace) -> int:
    out = Path(args.out or f"results/videos/{args.agent}_{args.env_id}_{args.seed}.mp4")
    info = record_episode(
        args.agent, args.env_id, args.seed, out, policy=args.policy, max_steps=args.max_steps
    )
    outcome = "collision" if info["collision"] else "success" if info["success"] else "no collision, no goal"
    print(f"wrote {out}: {outcome} after {info['progress']:.1f} m")
    return 0
