"""Evaluates one agent on held-out seeds and appends one CSV row per episode as it ends.

Seeds start at 1,000,000 (disjoint from every training seed). Re-running the same command resumes: episodes
already in the CSV with the same settings (env id, env kwargs, policy file content) are skipped. A CSV holding
these episodes flown with other settings is refused rather than mixed in: pass another --out, or --overwrite
to move the old file aside. Prints the collision and success rates with Wilson 95 % intervals.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

from agents.analysis.csv_file import check_is_file_target
from agents.analysis.episode_record import EpisodeRow
from agents.analysis.records import OVERWRITE_HINT, read_episodes, start_new_file
from agents.analysis.statistics import format_summary, summarise
from agents.cli.arguments import add_env_argument, add_layouts_argument, add_tier_argument, env_id_of
from agents.common.folders import check_writable_folder
from agents.common.locations import SCRATCH_DIR
from agents.common.seeds import TEST_SEED_START, VALIDATION_SEED_START
from agents.evaluation import runner  # by module: tests stand in for runner.execute
from agents.evaluation.episode_tasks import EpisodeTask, pooled_over_training_seeds, record_label, rows_of
from agents.policies import (
    AGENT_NAMES,
    POLICY_OPTION_HELP,
    TRUST_PICKLE_HELP,
    load_agent,
    runs_to_fly,
    split_agent_name,
)
from agents.policies.external import canonical_spec, is_external_name
from agents.policies.sb3_models import SB3_ALGORITHMS, is_sb3_model_name, sb3_model_name
from flownav_env.settings_check import check_env_kwargs
from flownav_env.tiers import TIER_NAMES

HELP = "evaluate an agent on held-out seeds (CSV per episode, resumable)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--agent",
        help=f"who flies: {', '.join(AGENT_NAMES)}, or a training seed of a learned one (ppo_flow@3 flies "
        "results/policies/ppo_flow/seed_3.zip); a learned agent named alone flies its shipped training "
        "seeds in turn over the seeds, as the leaderboard does; or an agent of your own, "
        "my_pkg.my_module:make_agent or path/to/file.py:make_agent (a callable returning an object with "
        "stable-baselines3's predict, or such an object)",
    )
    parser.add_argument("--policy", help=POLICY_OPTION_HELP)
    parser.add_argument("--trust-pickle", action="store_true", help=TRUST_PICKLE_HELP)
    parser.add_argument(
        "--algo",
        choices=SB3_ALGORITHMS,
        help="with --policy and no --agent: a stable-baselines3 model of this algorithm, trained anywhere on a "
        "FlowNav env (only its parameters are read where its network can be rebuilt without unpickling)",
    )
    add_layouts_argument(parser, 20, "held-out layouts to fly (default: %(default)s)")
    parser.add_argument(
        "--seed-start",
        type=int,
        default=TEST_SEED_START,
        help=f"first seed (default: %(default)s, the test layouts; from {VALIDATION_SEED_START} for validation "
        "layouts, to decide on)",
    )
    add_tier_argument(
        parser,
        "clean",
        f"a suite tier ({', '.join(TIER_NAMES)}) or any Gymnasium id such as FlowNavSingle-v0 (default: %(default)s)",
    )
    add_env_argument(
        parser,
        "FlowNavEnv kwarg, repeatable (e.g. --env rotation_error=0.05; default: none, the env's defaults)",
    )
    parser.add_argument(
        "--out",
        default=str(SCRATCH_DIR / "evaluations" / "episodes.csv"),
        help="episodes CSV, appended and resumed (default: %(default)s)",
    )
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="move an existing --out to <name>.bak-<time> and start a new file (nothing is deleted)",
    )
    parser.add_argument(
        "--workers", type=int, default=1, help="local worker processes (default: %(default)s)"
    )


def run(args: argparse.Namespace) -> int:
    if args.algo:
        if args.agent or not args.policy:
            raise ValueError(
                "--algo goes with --policy model.zip and without --agent (the model is the agent)"
            )
        args.agent, args.policy = sb3_model_name(args.algo, args.policy), None
    if not args.agent:
        raise ValueError("give --agent (or --policy model.zip --algo ALGO)")
    split_agent_name(args.agent)
    if is_external_name(args.agent):  # resolved here, so a bad one fails before anything flies
        args.agent = args.agent if is_sb3_model_name(args.agent) else canonical_spec(args.agent)
        load_agent(args.agent, trust_pickle=args.trust_pickle)
    if args.layouts < 1:
        raise ValueError(f"--layouts must be >= 1, got {args.layouts}")
    check_evaluation_seeds(args.seed_start, args.layouts)
    env_id = env_id_of(args.tiers)
    env_kwargs = check_env_kwargs(dict(args.env), "command line", key="--env")
    factor, level = record_label(env_kwargs)
    runs, message = runs_to_fly(args.agent, args.policy)
    if message:
        print(message)
    # Layout by layout, each run's turn, so an interrupted evaluation leaves every seed with about as many.
    tasks = [
        EpisodeTask(
            runs[index % len(runs)],
            factor,
            level,
            seed,
            env_id,
            tuple(sorted(env_kwargs.items())),
            args.policy,
            trust_pickle=args.trust_pickle,
        )
        for index, seed in enumerate(range(args.seed_start, args.seed_start + args.layouts))
    ]
    out = Path(args.out)
    check_is_file_target(out)
    check_writable_folder(out.parent)  # before the first episode, not after it
    if args.overwrite:
        moved = start_new_file(out)
        if moved is not None:
            print(f"--overwrite: moved {out} to {moved}")
    # Ctrl-C raises EpisodesInterrupted, which flownav prints as one line (where the episodes are) with exit 130.
    flown = runner.execute(
        tasks, out, workers=args.workers, description=f"evaluate {args.agent}", remedy=OVERWRITE_HINT
    )
    episodes = read_episodes(out)
    rows: Sequence[EpisodeRow] = rows_of(tasks, episodes.rows)
    if len(runs) > 1:  # one row for the agent, its seeds pooled as the leaderboard's headline pools them
        rows = pooled_over_training_seeds(rows)
    print(format_summary(summarise(rows)))
    skipped = len(tasks) - flown
    print(
        f"flew {flown} episodes" + (f", {skipped} already in {out} (skipped)" if skipped else f" into {out}")
    )
    if episodes.skipped:
        print(
            f"{episodes.skipped} torn or corrupt rows of {out} were skipped (their episodes were flown again)"
        )
    return 0


def check_evaluation_seeds(seed_start: int, episodes: int) -> None:
    """Refuse seeds a run may not evaluate on: training layouts, or a run that spans validation and test.

    Raises:
        ValueError: one line naming the seeds and the allowed ranges.
    """
    if seed_start < VALIDATION_SEED_START:
        raise ValueError(
            f"--seed-start must be >= {VALIDATION_SEED_START} (training uses the seeds below), got {seed_start}"
        )
    if seed_start < TEST_SEED_START < seed_start + episodes:
        raise ValueError(
            f"seeds {seed_start}-{seed_start + episodes - 1} span validation and test layouts: stay below "
            f"{TEST_SEED_START} (validation, to decide on) or start at {TEST_SEED_START} or later (test, to report)"
        )
