"""``score``: the one call that scores an agent on the suite (``flownav score`` is its command line), its episodes
into a folder of its own, its rows beside any other agent's scored there.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

from agents.analysis.records import overwrite_hint, start_new_file
from agents.common.folders import check_writable_folder
from agents.common.manifest import manifest_problem
from agents.common.seeds import SUITE_LAYOUTS
from agents.evaluation.runner import execute
from agents.evaluation.suite import (
    EPISODES_CSV,
    agent_runs,
    parse_tiers,
    resolve_agent,
    suite_rows,
    suite_tasks,
    summarise_suite,
    write_summary_csv,
)
from agents.evaluation.suite_report import SCORE_CSV, SuiteRow, other_agents_rows, write_score_runs
from agents.policies.agent_limits import DEFAULT_STEP_TIMEOUT_S, UNLISTED_POLICY_OPTION, AgentLimits
from agents.policies.external import check_display_name, display_name
from agents.policies.sandbox import make_undumpable
from flownav_env.tiers import SUITE_VERSION


def score(
    agent: str,
    *,
    tiers: str | Sequence[str] = "all",
    layouts: int = SUITE_LAYOUTS,
    out: str | Path = "runs/score",
    policy: str | None = None,
    trust_pickle: bool = False,
    workers: int = 1,
    backend: str = "local",
    address: str | None = None,
    name: str | None = None,
    overwrite: bool = False,
    step_timeout_s: float = DEFAULT_STEP_TIMEOUT_S,
    version: str = SUITE_VERSION,
    agent_limits: AgentLimits | None = None,
    unlisted_policy: bool = False,
) -> list[SuiteRow]:
    """Fly ``agent`` on suite ``version`` and return its rows (:data:`SUMMARY_COLUMNS`), one per tier.

    Episodes are appended to ``<out>/suite_episodes.csv`` (calling again resumes); the rows are written to
    ``<out>/score.csv`` beside the rows of any other agent scored into ``out`` (an agent's earlier rows are
    replaced), which ``flownav leaderboard --include`` sets beside the published table.

    Args:
        agent: a FlowNav agent name, ``my_pkg.my_module:make_agent``, ``path/to/file.py:make_agent``, or
            ``<algo>:<model.zip>`` for a stable-baselines3 model.
        tiers: ``"all"`` or tier names.
        layouts: how many of the frozen layouts (the table's rows say how many).
        out: output folder.
        policy: a learned agent's policy file, if not the shipped one.
        trust_pickle: allow unpickling a policy zip without its config (runs its code).
        workers: local worker processes; backend: ``"local"`` or ``"ray"``; address: a Ray cluster's.
        name: the rows' agent column (default :func:`~agents.policies.external.display_name`: a file's agent
            as ``my_agent:make_agent``); episode records keep the full spec and its file's hash.
        overwrite: move ``suite_episodes.csv`` to ``suite_episodes.csv.bak-<time>`` first and start afresh.
        step_timeout_s: the most an outside agent's ``predict`` may take per call (0: no limit); past it the
            run stops with one line naming the episode, and that episode is not recorded.
        agent_limits: the memory and CPU time an outside agent's process may use, and whether it is sandboxed.
        unlisted_policy: score a FlowNav agent with a ``policy`` its folder's ``MANIFEST.sha256`` does not list
            with this hash; its rows are then named for the file, never as the published agent.

    Raises:
        ValueError: a bad agent, tier, layout count, folder or name; an agent that needs an observation key or
            setting a tier does not give.
    """
    tier_names = parse_tiers(tiers)
    make_undumpable()  # the process that writes the rows, too: closed to other processes of this user
    agent = resolve_agent(agent, trust_pickle=trust_pickle, limits=agent_limits)
    default_name = display_name(agent)
    if policy is not None and (problem := manifest_problem(Path(policy))) is not None:
        if not unlisted_policy:
            raise ValueError(
                f"--policy: {problem}; its rows would stand under {agent}'s name: pass {UNLISTED_POLICY_OPTION} to "
                "score it anyway, under a name that says so"
            )
        default_name = f"{agent} ({Path(policy).name}, unlisted)"
    shown = check_display_name(default_name if name is None else name, agent)
    runs = {agent: agent_runs(agent, policy)}
    tasks = suite_tasks(
        runs, tier_names, layouts, policies={agent: policy}, trust_pickle=trust_pickle, version=version
    )
    out = Path(out)
    check_writable_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    csv_path = out / EPISODES_CSV
    if overwrite and (moved := start_new_file(csv_path)) is not None:
        print(f"--overwrite: moved {csv_path} to {moved}")
    execute(
        tasks,
        csv_path,
        backend=backend,
        workers=workers,
        address=address,
        description=f"score {shown}",
        remedy=overwrite_hint("folder"),
        step_timeout_s=step_timeout_s,
        by_factor=True,
        agent_limits=agent_limits,
    )
    rows = suite_rows(tasks, csv_path)
    table: list[SuiteRow] = [
        {**row, "agent": shown} for row in summarise_suite(rows, runs, tier_names, layouts, version)
    ]
    kept: list[Mapping[str, object]] = [*other_agents_rows(out / SCORE_CSV, shown, runs[agent], version)]
    write_summary_csv(out / SCORE_CSV, [*kept, *table])
    write_score_runs(out, shown, runs[agent])
    return table
