"""``flownav verify score.csv --agent FILE:FACTORY``: check the rows ``flownav score`` wrote against their agent.

The rates must be what the episodes beside the file (``suite_episodes.csv``) give, and a sample of those
episodes (``--sample`` per tier, drawn only once the files are given) is flown again here: each must end as the
file says (FlowNav's env is deterministic on one machine). Prints ``verified k/k`` and writes
``verification.json`` beside the file, which ``flownav leaderboard --include`` reads to mark the rows verified;
else names the first mismatch and exits 1. The agent is given as to ``flownav score``: ``--agent``, or
``--policy model.zip --algo ALGO``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from agents.cli.score import (
    add_agent_limit_arguments,
    add_agent_spec_arguments,
    agent_and_policy,
    agent_limits,
)
from agents.cli.suite import add_suite_version_argument
from agents.policies.agent_limits import DEFAULT_STEP_TIMEOUT_S, STEP_TIMEOUT_OPTION

HELP = "check a score.csv against its agent: its rates against its episodes, a random sample of them re-flown"
DEFAULT_SAMPLE = 10  # agents.evaluation.verify.DEFAULT_SAMPLE, here so that --help stays quick


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("score_csv", metavar="SCORE_CSV", help="what flownav score wrote (<out>/score.csv)")
    add_agent_spec_arguments(
        parser, "the agent the rows are of: a FlowNav agent, my_pkg.my_module:make_agent, or file.py:make_agent"
    )
    parser.add_argument(
        "--sample",
        type=int,
        default=DEFAULT_SAMPLE,
        help="episodes per tier to fly again, drawn at random now (default: %(default)s)",
    )
    parser.add_argument("--episodes", help="the episodes file (default: suite_episodes.csv beside SCORE_CSV)")
    parser.add_argument(
        STEP_TIMEOUT_OPTION,
        type=float,
        default=DEFAULT_STEP_TIMEOUT_S,
        metavar="SECONDS",
        help="the most an outside agent's predict may take per call (default: %(default)s; 0 = no limit)",
    )
    add_agent_limit_arguments(parser)
    add_suite_version_argument(parser)


def run(args: argparse.Namespace) -> int:
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.evaluation.verification_record import write_verification
    from agents.evaluation.verify import verify

    agent, policy = agent_and_policy(args)
    result = verify(
        args.score_csv,
        agent,
        policy=policy,
        trust_pickle=args.trust_pickle,
        sample=args.sample,
        episodes_csv=args.episodes,
        step_timeout_s=args.step_timeout,
        agent_limits=agent_limits(args),
        version=args.suite_version,
    )
    print(result.line())
    if result.mismatch:
        return 1
    written = write_verification(Path(args.score_csv), result.checked, args.episodes)
    print(f"written to {written}: flownav leaderboard --include {args.score_csv} marks these rows verified")
    return 0
