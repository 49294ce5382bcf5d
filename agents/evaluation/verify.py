"""Checking a ``score.csv`` against its agent: its rates against the episodes beside it, then a sample of those
episodes flown again (``flownav verify``).

FlowNav's env is deterministic on one machine: an episode flown again with the same agent, tier and layout ends
the same way. So a row anyone includes can be checked by anyone with the agent: its rates must be what the
episodes file beside it gives (``suite_episodes.csv``, only episodes of the agent given, with its file's hash),
and a sample of those episodes, drawn only once the files are given (a fresh random seed, so no one can know
which episodes will be flown), must end as the file says.
"""

from __future__ import annotations

import math
import secrets
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from agents.analysis.detection import (
    DEFAULT_CHANGED_SHARE,
    DEFAULT_POWER,
    DISCORDANCE_ALPHA,
    detection_power,
    detection_sample_size,
    discordance_p_value,
)
from agents.analysis.episode_record import row_outcome
from agents.common.machine import cpu_signature
from agents.evaluation.agent_settings import plan_settings
from agents.evaluation.episode_tasks import EpisodeTask, TieredRow
from agents.evaluation.runner import FlightCache, run_task
from agents.evaluation.suite import (
    EPISODES_CSV,
    agent_runs,
    resolve_agent,
    suite_rows,
    suite_tasks,
    summarise_suite,
)
from agents.evaluation.suite_report import OUTCOMES, SuiteRow, outcome_interval, read_suite_csv
from agents.policies.agent_limits import AgentLimits
from agents.policies.agent_process import end_agent_processes
from flownav_env.tiers import SUITE_VERSION

# The CPU this process flies on (an episode row records the one it flew on).
CPU = cpu_signature()
# score.csv keeps rates to 4 decimals (suite.write_summary_csv).
RATE_DECIMALS = 4


@dataclass(frozen=True)
class Verification:
    """What ``verify`` found: the episodes flown again (``checked``, of ``sampled``, drawn from ``total``), the
    first that did not match (``mismatch``, one line; "" when all did), and of those flown on another CPU than
    this one (``other_cpu``) how many ended as the file says (``agreed_other_cpu``) and the p-value that the file
    fails less often than the agent does (``p_value``)."""

    checked: int
    sampled: int
    total: int = 0
    mismatch: str = ""
    other_cpu: int = 0
    agreed_other_cpu: int = 0
    p_value: float = 1.0
    changed_share: float = DEFAULT_CHANGED_SHARE
    power: float = DEFAULT_POWER

    @property
    def exact(self) -> bool:
        """Whether every episode flown again was flown on this CPU, so each was compared bit for bit."""
        return self.other_cpu == 0

    def line(self) -> str:
        """``verified k/k`` and how, or the first mismatch."""
        if self.mismatch:
            return f"not verified: {self.mismatch}"
        caught = (
            f"a file with {self.changed_share * 100:g} % of its {self.total:,} episodes changed is caught "
            f"{100 * detection_power(self.total, _changed(self.total, self.changed_share), self.sampled):.0f} % of "
            "the time"
        )
        if self.exact:
            return f"verified {self.checked}/{self.sampled}: each ends as the file says ({caught})"
        return (
            f"verified {self.checked}/{self.sampled}, {self.other_cpu} of them statistically: the file flew them on "
            f"another CPU than this one ({CPU}), where a learned policy's floats differ; {self.agreed_other_cpu} of "
            f"{self.other_cpu} end as the file says, and the file does not fail less often than a re-flight "
            f"(p = {self.p_value:.2f}); those on this CPU each end as the file says ({caught})"
        )


def _changed(total: int, share: float) -> int:
    return max(1, math.ceil(share * total - 1e-9))


def verify(
    score_csv: str | Path,
    agent: str,
    *,
    policy: str | None = None,
    trust_pickle: bool = False,
    sample: int | None = None,
    changed_share: float = DEFAULT_CHANGED_SHARE,
    power: float = DEFAULT_POWER,
    episodes_csv: str | Path | None = None,
    step_timeout_s: float = 0.0,
    agent_limits: AgentLimits | None = None,
    version: str = SUITE_VERSION,
) -> Verification:
    """Check ``score_csv``'s rows against ``agent``: their rates against its episodes, then ``sample`` episodes
    per tier flown again here, each of which must end as the file says.

    Args:
        score_csv: what ``flownav score`` wrote.
        agent: the agent the rows are of (a FlowNav name, ``file.py:factory``, ``module:factory``,
            ``<algo>:<model.zip>``).
        policy: a learned agent's policy file, if not the shipped one.
        trust_pickle: allow unpickling a policy zip without its config (runs its code).
        sample: episodes to fly again, drawn from all of the file's (default: as many as catch a file with
            ``changed_share`` of its episodes changed with probability ``power``).
        changed_share, power: what the default sample is sized to catch.
        episodes_csv: the episodes file (default: ``suite_episodes.csv`` beside ``score_csv``).
        step_timeout_s, agent_limits: as ``flownav score``'s.
        version: the suite version the rows are of.

    Raises:
        ValueError: a bad sample size, a file that is not a score CSV, rows of several agents, or an episodes
            file that holds none of the agent's episodes.
        FileNotFoundError: no such file.
    """
    if sample is not None and (isinstance(sample, bool) or not isinstance(sample, int) or sample < 1):
        raise ValueError(f"--sample must be an integer >= 1, got {sample!r}")
    detection_sample_size(1, changed_share, power)  # a bad share or power fails before anything flies
    score_csv = Path(score_csv)
    rows = _one_agents_rows(score_csv, version)
    episodes_path = Path(episodes_csv) if episodes_csv else score_csv.parent / EPISODES_CSV
    if not episodes_path.is_file():
        raise FileNotFoundError(
            f"no episodes file at {episodes_path}: flownav score writes it beside score.csv"
        )
    agent = resolve_agent(agent, trust_pickle=trust_pickle, limits=agent_limits)
    runs = {agent: agent_runs(agent, policy)}
    tasks: dict[str, list[EpisodeTask]] = {}
    for row in rows:
        tasks[row["tier"]] = suite_tasks(
            runs,
            [row["tier"]],
            row["layouts"],
            policies={agent: policy},
            trust_pickle=trust_pickle,
            version=version,
        )
    episodes = {tier: suite_rows(tier_tasks, episodes_path) for tier, tier_tasks in tasks.items()}
    if not any(episodes.values()):
        raise ValueError(
            f"{episodes_path} holds no episodes of {agent} as it is now (same file hash, settings and layouts): "
            "is that the agent the rows are of?"
        )
    mismatch = _rates_mismatch(rows, episodes, runs, score_csv, version)
    if mismatch:
        return Verification(0, 0, mismatch=mismatch)
    total = sum(len(found) for found in episodes.values())
    size = sample if sample is not None else detection_sample_size(total, changed_share, power)
    found = _fly_sample(tasks, episodes, size, step_timeout_s, agent_limits or AgentLimits())
    return replace(found, total=total, changed_share=changed_share, power=power)


def _one_agents_rows(score_csv: Path, version: str) -> list[SuiteRow]:
    """The rows of ``score_csv``, all of one agent.

    Raises:
        ValueError: no rows, or rows of several agents.
    """
    rows = read_suite_csv(score_csv, version)
    if not rows:
        raise ValueError(f"{score_csv} holds no rows: flownav score writes one per tier it flew whole")
    names = sorted({row["agent"] for row in rows})
    if len(names) > 1:
        raise ValueError(
            f"{score_csv} holds rows of {len(names)} agents ({', '.join(names)}): verify one at a time"
        )
    return rows


def _rates_mismatch(
    rows: Sequence[SuiteRow],
    episodes: Mapping[str, list[TieredRow]],
    runs: Mapping[str, Sequence[str]],
    score_csv: Path,
    version: str,
) -> str:
    """The first rate of ``rows`` that the episodes do not give, in words; "" when every one matches."""
    for row in rows:
        summaries = summarise_suite(episodes[row["tier"]], runs, [row["tier"]], row["layouts"], version)
        if not summaries:
            return f"{score_csv}, tier {row['tier']}: the episodes file lacks some of its {row['layouts']} layouts"
        summary = summaries[0]
        for outcome in OUTCOMES:
            for part, given, exact in zip(
                ("rate", "low", "high"),
                outcome_interval(row, outcome),
                outcome_interval(summary, outcome),
                strict=True,
            ):
                column = f"{outcome}_{part}"
                flown = round(exact, RATE_DECIMALS)
                if not math.isclose(given, flown, abs_tol=10**-RATE_DECIMALS):
                    return f"{score_csv}, tier {row['tier']}: {column} is {given:g}, but its episodes give {flown:g}"
    return ""


def _fly_sample(
    tasks: Mapping[str, list[EpisodeTask]],
    episodes: Mapping[str, list[TieredRow]],
    sample: int,
    step_timeout_s: float,
    limits: AgentLimits,
) -> Verification:
    """Fly ``sample`` of all the file's episodes, drawn here with a fresh seed, and compare each one's outcome:
    exactly where the file flew it on this CPU, by its success against the file's otherwise."""
    draw = np.random.default_rng(secrets.randbits(128))
    pairs: list[tuple[EpisodeTask, TieredRow]] = []
    for tier, tier_tasks in tasks.items():
        recorded = {(row["agent"], int(row["seed"])): row for row in episodes[tier]}
        pairs += [
            (task, recorded[(task.agent, task.seed)])
            for task in tier_tasks
            if (task.agent, task.seed) in recorded
        ]
    picks = sorted(draw.choice(len(pairs), size=min(sample, len(pairs)), replace=False))
    chosen = [pairs[index] for index in picks]
    flown = plan_settings(
        [replace(task, step_timeout_s=step_timeout_s, agent_limits=limits) for task, _ in chosen]
    )
    cache = FlightCache()
    checked = other = agreed = file_better = file_worse = 0
    try:
        for task, (_, row) in zip(flown, chosen, strict=True):
            again = vars(run_task(task, cache))
            said, now = row_outcome(row), row_outcome(again)
            checked += 1
            if row.get("cpu") != CPU:  # another CPU, or a file from before episodes recorded theirs
                other += 1
                agreed += said == now
                file_better += said == "success" and now != "success"
                file_worse += said != "success" and now == "success"
            elif said != now:
                return Verification(
                    checked - 1,
                    len(chosen),
                    mismatch=f"the episode of {task.agent} on tier {task.tier}, layout seed {task.seed}: the file "
                    f"says {said}, flown again on the CPU it was flown on it ends in {now}",
                )
    finally:
        cache.clear()
        end_agent_processes()
    p_value = discordance_p_value(file_better, file_worse)
    if p_value < DISCORDANCE_ALPHA:
        return Verification(
            checked,
            len(chosen),
            mismatch=f"of {other} episodes the file flew on another CPU, {file_better} it records as successes fail "
            f"when flown again here and only {file_worse} the other way: the file fails less often than its agent "
            f"(p = {p_value:.3f})",
        )
    return Verification(checked, len(chosen), other_cpu=other, agreed_other_cpu=agreed, p_value=p_value)
