"""``flownav score``: score any agent on the suite's frozen test layouts, one row per tier.

The agent is a FlowNav agent name, one of your own (``my_pkg.my_module:make_agent`` or
``path/to/file.py:make_agent``: a callable returning an object with stable-baselines3's ``predict``, or such an
object), or a stable-baselines3 model (``--policy model.zip --algo sac``). Writes ``<out>/suite_episodes.csv``
(resumable) and ``<out>/score.csv``; ``flownav leaderboard --include <out>/score.csv`` sets the rows beside the
published table. What the agent is given and must return (observation keys, shapes and meaning; the action and
its units; ``predict``'s signature): ``flownav describe [--tiers TIER]``. ``--name`` sets the name its rows show
(default: the file's stem and callable, ``my_agent:make_agent``). In Python: ``agents.evaluation.scoring.score``.
``--robustness`` adds the agent's failure-versus-error curves on the sweep's sensor factors
(``agents.studies.robustness.robustness``).

Before flying it says what ``suite_episodes.csv`` already holds of each tier and what is left. After you edit
your agent's file its old episodes no longer describe it: ``--overwrite`` starts afresh, keeping the old file
as ``suite_episodes.csv.bak-<time>``. An outside agent (a file, a module, a model zip) runs in a process of its
own, apart from the env: its ``predict`` gets ``--step-timeout`` seconds a call, its process ``--agent-memory``
GiB and ``--agent-cpu`` seconds of CPU time.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from agents.cli.arguments import announce_flight
from agents.cli.suite import add_tier_arguments
from agents.pages.suite_tables import tier_tables
from agents.policies import POLICY_OPTION_HELP, TRUST_PICKLE_HELP
from agents.policies.agent_limits import (
    AGENT_CPU_OPTION,
    AGENT_MEMORY_OPTION,
    DEFAULT_AGENT_CPU_S,
    DEFAULT_AGENT_MEMORY_GIB,
    DEFAULT_STEP_TIMEOUT_S,
    NO_SANDBOX_OPTION,
    STEP_TIMEOUT_OPTION,
    UNLISTED_POLICY_OPTION,
    AgentLimits,
)
from agents.policies.sb3_models import SB3_ALGORITHMS, sb3_model_name

HELP = "score any agent on the suite's frozen test layouts (a row per tier)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_agent_spec_arguments(
        parser, "a FlowNav agent, my_pkg.my_module:make_agent, or path/to/file.py:make_agent"
    )
    parser.add_argument(
        "--name",
        help="the agent's name in score.csv, tables and figures (default: a file's stem and callable, e.g. "
        "my_agent:make_agent; episode records keep the full path and the file's hash)",
    )
    add_tier_arguments(parser)
    parser.add_argument("--out", default="runs/score", help="output folder (default: %(default)s)")
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="start a new suite_episodes.csv: the old one is moved to suite_episodes.csv.bak-<time>, nothing "
        "is deleted (after editing your agent, whose old episodes no longer describe it)",
    )
    parser.add_argument(
        STEP_TIMEOUT_OPTION,
        type=float,
        default=DEFAULT_STEP_TIMEOUT_S,
        metavar="SECONDS",
        help="the most an outside agent's predict may take per call; past it the run stops, naming the "
        "episode (default: %(default)s; 0 = no limit)",
    )
    add_agent_limit_arguments(parser)
    parser.add_argument(
        UNLISTED_POLICY_OPTION,
        action="store_true",
        help="score a FlowNav agent with a --policy its folder's MANIFEST.sha256 does not list with its hash; its "
        "rows are named for the file, never as the published agent (without this it is refused)",
    )
    parser.add_argument(
        "--robustness",
        action="store_true",
        help="also fly the agent's failure-versus-error curve for each sensor factor of configs/sweep.yaml, on "
        "the sweep's layouts: robustness.csv, robustness_summary.csv (each curve's area and breaking level), "
        "robustness.png",
    )
    parser.add_argument(
        "--factors", help="with --robustness: comma-separated sensor factors (default: all of the sweep's)"
    )
    parser.add_argument(
        "--robustness-layouts",
        type=int,
        help="with --robustness: the first N of the sweep's layouts per cell (default: the sweep's count)",
    )


def add_agent_limit_arguments(parser: argparse.ArgumentParser) -> None:
    """``--agent-memory``, ``--agent-cpu`` and ``--no-sandbox``: what an outside agent's process may use, and
    where."""
    parser.add_argument(
        AGENT_MEMORY_OPTION,
        type=float,
        default=DEFAULT_AGENT_MEMORY_GIB,
        metavar="GIB",
        help="the address space an outside agent's process may map, in GiB; past it its allocations fail "
        "(default: %(default)s)",
    )
    parser.add_argument(
        AGENT_CPU_OPTION,
        type=float,
        default=DEFAULT_AGENT_CPU_S,
        metavar="SECONDS",
        help="the CPU time an outside agent's process may use over the run; past it the process is killed and "
        "the run stops, naming the episode (default: %(default)s)",
    )
    parser.add_argument(
        NO_SANDBOX_OPTION,
        action="store_true",
        help="fly an outside agent in a plain process of its own, without the sandbox (bubblewrap) that keeps it "
        "from your files, the scorer's memory and the network; its episode rows say so",
    )


def agent_limits(args: argparse.Namespace) -> AgentLimits:
    """The :class:`AgentLimits` of ``--agent-memory``, ``--agent-cpu`` and ``--no-sandbox``."""
    return AgentLimits(args.agent_memory, args.agent_cpu, sandboxed=not args.no_sandbox)


def agent_and_policy(args: argparse.Namespace) -> tuple[str, str | None]:
    """The agent ``--agent``, ``--policy`` and ``--algo`` name, and its policy file where it has one.

    Raises:
        ValueError: ``--algo`` without ``--policy`` or with ``--agent``, or no agent.
    """
    agent, policy = args.agent, args.policy
    if args.algo:
        if agent or not policy:
            raise ValueError(
                "--algo goes with --policy model.zip and without --agent (the model is the agent)"
            )
        agent, policy = sb3_model_name(args.algo, policy), None
    if not agent:
        raise ValueError("give --agent (or --policy model.zip --algo ALGO)")
    return agent, policy


def run(args: argparse.Namespace) -> int:
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.evaluation.scoring import score

    agent, policy = agent_and_policy(args)
    if not args.robustness and (args.factors or args.robustness_layouts is not None):
        raise ValueError("--factors and --robustness-layouts go with --robustness")
    if args.robustness:
        # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
        from agents.studies.robustness import robustness_cells

        robustness_cells(args.factors, args.robustness_layouts)  # bad options fail before anything flies
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.evaluation.suite import agent_runs, parse_tiers
    from agents.policies.external import is_external_name

    runs = 1 if is_external_name(agent) else len(agent_runs(agent, policy))
    announce_flight(
        "score",
        runs * len(parse_tiers(args.tiers)) * args.layouts,
        args.workers,
        "--layouts 10 is a quick look, --tiers clean one tier",
    )
    # What both flights share: the agent's policy file and where the episodes fly.
    common = {
        "policy": policy,
        "trust_pickle": args.trust_pickle,
        "workers": args.workers,
        "backend": args.backend,
        "address": args.address,
    }
    rows = score(
        agent,
        tiers=args.tiers,
        layouts=args.layouts,
        out=Path(args.out),
        name=args.name,
        overwrite=args.overwrite,
        step_timeout_s=args.step_timeout,
        version=args.suite_version,
        agent_limits=agent_limits(args),
        unlisted_policy=args.unlisted_policy,
        **common,
    )
    print("\n".join(tier_tables(rows)))
    print(
        f"rows written to {Path(args.out) / 'score.csv'}; set them beside the published table with "
        f"flownav leaderboard --include {Path(args.out) / 'score.csv'}"
    )
    if args.robustness:
        # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
        from agents.evaluation.suite import resolve_agent
        from agents.studies.robustness import robustness, summary_lines

        summary = robustness(
            resolve_agent(agent, trust_pickle=args.trust_pickle, limits=agent_limits(args)),
            Path(args.out),
            factors=args.factors,
            layouts=args.robustness_layouts,
            agent_limits=agent_limits(args),
            step_timeout_s=args.step_timeout,
            **common,
        )
        print("\n".join(summary_lines(summary)))
        print(
            f"robustness curves written to {Path(args.out) / 'robustness.csv'} and robustness.png; the published "
            "agents' are in results/sweep.md"
        )
    return 0


def add_agent_spec_arguments(parser: argparse.ArgumentParser, agent_help: str) -> None:
    """The options that name one agent to fly, shared by ``score`` and ``verify``: ``--agent`` (``agent_help``),
    or ``--policy`` with ``--algo``, and ``--trust-pickle``."""
    parser.add_argument("--agent", help=agent_help)
    parser.add_argument("--policy", help=POLICY_OPTION_HELP)
    parser.add_argument(
        "--algo", choices=SB3_ALGORITHMS, help="with --policy and no --agent: a stable-baselines3 model"
    )
    parser.add_argument("--trust-pickle", action="store_true", help=TRUST_PICKLE_HELP)
