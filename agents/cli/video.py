"""``flownav video``: an mp4 of one episode of an agent, with the flow overlay.

Encoded with imageio's ffmpeg plugin (``imageio-ffmpeg``, a declared dependency), not gymnasium's
``RecordVideo``, which needs moviepy. A learned policy flies with the env settings of the config beside its
zip.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

from agents.cli.arguments import add_seed_start_argument, add_tier_argument, env_id_of
from agents.common.locations import SCRATCH_DIR
from agents.common.seeds import TEST_SEED_START
from agents.policies import AGENT_NAMES, POLICY_OPTION_HELP, TRUST_PICKLE_HELP, runs_to_fly
from flownav_env.tiers import TIER_NAMES

HELP = "record an mp4 of an agent's episode with the flow overlay"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--agent",
        required=True,
        help=f"{', '.join(AGENT_NAMES)}, or a training seed such as ppo_flow@0 (a learned agent named alone flies "
        "its first shipped training seed)",
    )
    parser.add_argument("--policy", help=POLICY_OPTION_HELP)
    parser.add_argument("--trust-pickle", action="store_true", help=TRUST_PICKLE_HELP)
    add_tier_argument(
        parser,
        "clean",
        f"a suite tier ({', '.join(TIER_NAMES)}) or any Gymnasium id such as FlowNavSingle-v0 (default: %(default)s)",
    )
    add_seed_start_argument(parser, TEST_SEED_START, "the layout seed flown (default: %(default)s)")
    parser.add_argument("--out", help=f"mp4 path (default {SCRATCH_DIR}/videos/<agent>_<env-id>_<seed>.mp4)")
    parser.add_argument("--max-steps", type=int, default=600)


def run(args: argparse.Namespace) -> int:
    runs, message = runs_to_fly(args.agent, args.policy)
    args.agent = runs[0]
    if message:
        print(f"{message}; this video flies {args.agent}")
    env_id = env_id_of(args.tiers)
    out = Path(args.out or SCRATCH_DIR / "videos" / f"{args.agent}_{env_id}_{args.seed_start}.mp4")
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.studies.video import record_episode
    from flownav_env import ignore_v0_out_of_date

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ignore_v0_out_of_date()
        info = record_episode(
            args.agent,
            env_id,
            args.seed_start,
            out,
            policy=args.policy,
            max_steps=args.max_steps,
            trust_pickle=args.trust_pickle,
        )
    for warning in caught:
        print(f"flownav video: warning: {warning.message}", file=sys.stderr)
    outcome = "collision" if info["collision"] else "success" if info["success"] else "no collision, no goal"
    print(f"wrote {out}: {outcome} after {info['progress']:.1f} m")
    return 0
