"""``flownav verify score.csv --agent FILE:FACTORY``: check the rows ``flownav score`` wrote against their agent.

The rates must be what the episodes beside the file (``suite_episodes.csv``) give, and a sample of those
episodes, drawn only once the files are given and sized to catch a file with ``--detect`` (2 %) of its episodes
changed with probability ``--power`` (95 %), is flown again here. An episode the file flew on this CPU must end as
the file says (FlowNav's env is deterministic on one machine); episodes flown on another CPU, where a learned
policy's floats differ, are compared statistically: the file must not fail less often than they do when flown
again (an exact McNemar test). Prints ``verified k/k`` and how, and writes ``verification.json`` beside the file,
signed with this user's key, which ``flownav leaderboard --include`` reads to mark the rows verified; else names
the first mismatch and exits 1. The agent is given as to ``flownav score``: ``--agent``, or
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
# agents.analysis.detection's defaults, here so that --help stays quick.
DEFAULT_CHANGED_SHARE = 0.02
DEFAULT_POWER = 0.95


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("score_csv", metavar="SCORE_CSV", help="what flownav score wrote (<out>/score.csv)")
    add_agent_spec_arguments(
        parser,
        "the agent the rows are of: a FlowNav agent, my_pkg.my_module:make_agent, or file.py:make_agent",
    )
    parser.add_argument(
        "--sample",
        type=int,
        help="episodes to fly again, drawn at random now from all the file's (default: as many as catch a file "
        "with --detect of its episodes changed with probability --power)",
    )
    parser.add_argument(
        "--detect",
        type=float,
        default=DEFAULT_CHANGED_SHARE,
        metavar="SHARE",
        help="the share of changed episodes the default sample is sized to catch (default: %(default)s)",
    )
    parser.add_argument(
        "--power",
        type=float,
        default=DEFAULT_POWER,
        help="the probability with which the default sample catches them (default: %(default)s)",
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
    from agents.common.machine import cpu_signature
    from agents.evaluation.verification_record import write_verification
    from agents.evaluation.verify import verify

    agent, policy = agent_and_policy(args)
    result = verify(
        args.score_csv,
        agent,
        policy=policy,
        trust_pickle=args.trust_pickle,
        sample=args.sample,
        changed_share=args.detect,
        power=args.power,
        episodes_csv=args.episodes,
        step_timeout_s=args.step_timeout,
        agent_limits=agent_limits(args),
        version=args.suite_version,
    )
    print(result.line())
    if result.mismatch:
        return 1
    written = write_verification(
        Path(args.score_csv),
        result.checked,
        args.episodes,
        statistically=result.other_cpu,
        cpu=cpu_signature(),
    )
    print(f"written to {written}: flownav leaderboard --include {args.score_csv} marks these rows verified")
    return 0
