"""The main job in a few minutes: flies every reactive agent (the straight floor, the bee, ``bee_robust``, ``bee_ttc``,
``vfh``) and every shipped PPO agent on the same few held-out seeds of FlowNav-v0 and prints the comparison
table (collision and success rates with Wilson 95 % intervals). A learned agent flies its shipped training
seeds (``results/policies/<agent>/seed_<k>.zip``) in turn over the layouts, as the sweep does; one without
any flies its single ``<agent>.zip`` if there is one, and says so. A few episodes cannot rank agents, so the
table comes with how few it rests on and where the leading table is: ``results/suite.md``, every agent on every
tier's 300 frozen test layouts (``flownav suite``). The layouts flown here are the first of the clean tier's
history table, ``results/leaderboard.md`` (``flownav leaderboard``), which are other layouts than the suite's."""

from __future__ import annotations

import argparse
import tempfile
from collections.abc import Sequence
from pathlib import Path

from agents.analysis.records import read_records
from agents.analysis.statistics import CellSummary, format_summary, summarise
from agents.cli.arguments import add_workers_argument
from agents.common.locations import POLICIES_DIR, RESULTS_DIR
from agents.common.seeds import SUITE_LAYOUTS, SUITE_SEED_START, TEST_SEED_START
from agents.evaluation import runner  # by module: tests stand in for runner.execute
from agents.evaluation.episode_tasks import EpisodeTask, pooled_over_training_seeds
from agents.policies import LEARNED_AGENTS, REACTIVE_AGENTS, default_runs, is_learned, policy_file
from flownav_env.tiers import TIER_NAMES

HELP = "short evaluation of the shipped policies and the baselines (the README's main job)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--episodes", type=int, default=5, help="episodes per agent (default: %(default)s)")
    parser.add_argument("--env-id", default="FlowNav-v0", help="Gymnasium env id (default: %(default)s)")
    parser.add_argument(
        "--policies-dir",
        "--policy-dir",  # the demo's first spelling, kept; --policies-dir as leaderboard has it
        dest="policies_dir",
        default=str(POLICIES_DIR),
        help="folder of the PPO policies, <agent>/seed_<k>.zip or <agent>.zip (default: this repository's "
        "%(default)s)",
    )
    add_workers_argument(parser)


def run(args: argparse.Namespace) -> int:
    if args.episodes < 1:
        raise ValueError(f"--episodes must be >= 1, got {args.episodes}")
    runs = {name: [name] for name in REACTIVE_AGENTS} | learned_runs(Path(args.policies_dir))
    seeds = range(TEST_SEED_START, TEST_SEED_START + args.episodes)
    tasks = []
    for names in runs.values():
        for index, seed in enumerate(seeds):
            name = names[index % len(names)]  # training seeds in turn over the layouts
            policy = str(policy_file(name, directory=args.policies_dir)) if is_learned(name) else None
            tasks.append(EpisodeTask(name, "clean", 0.0, seed, args.env_id, (), policy))
    with tempfile.TemporaryDirectory() as scratch:
        episodes = Path(scratch) / "demo.csv"
        try:
            runner.execute(tasks, episodes, workers=args.workers, description="demo")
        except runner.EpisodesInterrupted:
            # Its CSV was a scratch file: there is nothing to resume, whatever the runner's message says.
            raise KeyboardInterrupt("the demo keeps no episodes; run it again to start over") from None
        rows = pooled_over_training_seeds(read_records(episodes))
        table = summarise(rows)
    print(demo_report(table, args.env_id, args.episodes))
    return 0


def demo_report(table: Sequence[CellSummary], env_id: str, episodes: int) -> str:
    """The demo's table (rows of :func:`~agents.analysis.statistics.summarise`) without the columns that are
    the same in every row, under a line saying how few episodes it rests on and where the leading table is."""

    constant = [name for name in ("factor", "level") if len({row[name] for row in table}) <= 1]
    widest = max((row["failure_ci_high"] - row["failure_ci_low"] for row in table), default=0.0)
    plural = "" if episodes == 1 else "s"
    return (
        f"\n{env_id}, clean sensors, {episodes} held-out test layout{plural} per agent (layout seeds from "
        f"{TEST_SEED_START:,}).\n"
        f"Only {episodes} episode{plural} per agent: a quick look, not a ranking (the "
        f"widest 95 % interval below spans {widest:.2f}). The leading table, every agent on each of the "
        f"{len(TIER_NAMES)} tiers' {SUITE_LAYOUTS} frozen test layouts (seeds from {SUITE_SEED_START:,}) and "
        f"learned agents over all their training seeds, is {RESULTS_DIR / 'suite.md'} (flownav suite); these "
        f"layouts are the first of the clean tier's history table, {RESULTS_DIR / 'leaderboard.md'}, whose "
        "other layouts give other rates.\n\n" + format_summary(table, omit=constant)
    )


def learned_runs(policy_dir: Path) -> dict[str, list[str]]:
    """Each learned agent's runs to fly: its shipped training seeds (``ppo_flow@0``, ...), else its single
    ``<agent>.zip``; an agent with neither is left out. Says which, for every agent."""

    runs: dict[str, list[str]] = {}
    for agent in LEARNED_AGENTS:
        names, message = default_runs(agent, policy_dir)
        print(message if names else f"skipping {message}")
        if names:
            runs[agent] = names
    return runs
