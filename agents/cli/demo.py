"""The main job in a few minutes: flies the bee baseline, the straight floor and every shipped PPO policy on
the same few held-out seeds of FlowNav-v0 and prints the comparison table (collision and success rates with
Wilson 95 % intervals). The full benchmark is ``flownav sweep`` (results/benchmark.md)."""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from agents.common.paths import POLICIES_DIR
from agents.common.seeds import TEST_SEED_START

HELP = "short evaluation of the shipped policies and the baselines (the README's main job)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--episodes", type=int, default=5, help="episodes per agent (default: %(default)s)")
    parser.add_argument("--env-id", default="FlowNav-v0", help="Gymnasium env id (default: %(default)s)")
    parser.add_argument(
        "--policy-dir",
        default=str(POLICIES_DIR),
        help="folder of the PPO policies <agent>.zip (default: this repository's %(default)s)",
    )
    parser.add_argument(
        "--workers", type=int, default=2, help="local worker processes (default: %(default)s)"
    )


def run(args: argparse.Namespace) -> int:
    from agents.evaluation.records import read_records
    from agents.evaluation.runner import EpisodesInterrupted, EpisodeTask, execute
    from agents.evaluation.statistics import format_summary, summarise
    from agents.policies import LEARNED_AGENTS, policy_file

    if args.episodes < 1:
        raise ValueError(f"--episodes must be >= 1, got {args.episodes}")
    files = {name: policy_file(name, directory=args.policy_dir) for name in LEARNED_AGENTS}
    policies = {name: str(path) for name, path in files.items() if path.exists()}
    for name, path in files.items():
        if name not in policies:
            print(f"skipping {name}: no policy at {path}")
    agents = ["straight", "bee", *policies]
    seeds = range(TEST_SEED_START, TEST_SEED_START + args.episodes)
    tasks = [EpisodeTask(a, "clean", 0.0, s, args.env_id, (), policies.get(a)) for a in agents for s in seeds]
    with tempfile.TemporaryDirectory() as scratch:
        episodes = Path(scratch) / "demo.csv"
        try:
            execute(tasks, episodes, workers=args.workers, description="demo")
        except EpisodesInterrupted:
            # Its CSV was a scratch file: there is nothing to resume, whatever the runner's message says.
            raise KeyboardInterrupt("the demo keeps no episodes; run it again to start over") from None
        table = summarise(read_records(episodes))
    print(f"\n{args.env_id}, {args.episodes} held-out seeds per agent (from {TEST_SEED_START}):\n")
    print(format_summary(table))
    return 0
