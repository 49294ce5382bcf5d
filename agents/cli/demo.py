"""The main job in a few minutes: flies the bee baseline, the straight floor and every shipped PPO policy on
the same few held-out seeds of FlowNav-v0 and prints the comparison table (collision and success rates with
Wilson 95 % intervals). The full benchmark is ``flownav sweep`` (results/benchmark.md)."""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from agents.common.seeds import TEST_SEED_START

HELP = "short evaluation of the shipped policies and the baselines (the README's main job)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--episodes", type=int, default=5, help="episodes per agent (default 5)")
    parser.add_argument("--env-id", default="FlowNav-v0")
    parser.add_argument("--policy-dir", default="results/policies")
    parser.add_argument("--workers", type=int, default=2)


def run(args: argparse.Namespace) -> int:
    from agents.evaluation.records import read_records
    from agents.evaluation.runner import EpisodeTask, execute
    from agents.evaluation.statistics import format_summary, summarise
    from agents.policies import LEARNED_AGENTS, policy_file

    if args.episodes < 1:
        raise ValueError(f"--episodes must be >= 1, got {args.episodes}")
    files = {name: policy_file(name, directory=args.policy_dir) for name in LEARNED_AGENTS}
    policies = {name: str(path) for name, path in files.items() if path.exists()}
    agents = ["straight", "bee", *policies]
    seeds = range(TEST_SEED_START, TEST_SEED_START + args.episodes)
    tasks = [EpisodeTask(a, "clean", 0.0, s, args.env_id, (), policies.get(a)) for a in agents for s in seeds]
    with tempfile.TemporaryDirectory() as scratch:
        episodes = Path(scratch) / "demo.csv"
        execute(tasks, episodes, workers=args.workers, description="demo")
        table = summarise(read_records(episodes))
    print(f"\n{args.env_id}, {args.episodes} held-out seeds per agent (from {TEST_SEED_START}):\n")
    print(format_summary(table))
    return 0
