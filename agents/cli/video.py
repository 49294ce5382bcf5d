"""``flownav video``: an mp4 of one episode of an agent, with the flow overlay."""

from __future__ import annotations

import argparse
from pathlib import Path

from agents.common.seeds import TEST_SEED_START

HELP = "record an mp4 of an agent's episode with the flow overlay"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from agents.policies import AGENT_NAMES

    parser.add_argument("--agent", required=True, choices=AGENT_NAMES)
    parser.add_argument("--policy", help="PPO policy .zip (default results/policies/<agent>.zip)")
    parser.add_argument("--env-id", default="FlowNav-v0")
    parser.add_argument("--seed", type=int, default=TEST_SEED_START)
    parser.add_argument("--out", help="mp4 path (default results/videos/<agent>_<env-id>_<seed>.mp4)")
    parser.add_argument("--max-steps", type=int, default=600)


def run(args: argparse.Namespace) -> int:
    out = Path(args.out or f"results/videos/{args.agent}_{args.env_id}_{args.seed}.mp4")
    from agents.evaluation.video import record_episode

    info = record_episode(
        args.agent, args.env_id, args.seed, out, policy=args.policy, max_steps=args.max_steps
    )
    outcome = "collision" if info["collision"] else "success" if info["success"] else "no collision, no goal"
    print(f"wrote {out}: {outcome} after {info['progress']:.1f} m")
    return 0
