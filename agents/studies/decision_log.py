"""The decision log (``flownav decision-log``, ``results/decision_log.md``): each choice of ``configs/decisions.yaml``
beside what the repository's history says of it.

For each choice, read from git: when its commit was made, which agents' test rows of the suite version were
already committed then (the test results visible when it was chosen), and, for the agents it governs, how many of
their test rows were flown by code that descends from it (the choice committed before the flights) and how many
were not. Nothing here is typed by hand but the choices themselves.
"""

from __future__ import annotations

import csv
import io
import subprocess
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from agents.analysis.decision_rows import DECISION_CSV, AgentDecision, write_decision_rows
from agents.common.agent_table import base_agent_name
from agents.common.locations import CONFIGS_DIR, REPO_ROOT, RESULTS_DIR
from agents.common.tables import today
from agents.pages.wording import render_report

DECISIONS_FILE = CONFIGS_DIR / "decisions.yaml"
EPISODES = "results/suite_episodes.csv"
PAGE = "decision_log.md"


@dataclass(frozen=True)
class Decision:
    """One choice: what was chosen, the commit that made it, where it was validated, the agents it governs."""

    id: str
    chose: str
    commit: str
    validation: str
    governs: tuple[str, ...] = ()


@dataclass(frozen=True)
class LoggedDecision:
    """A choice with what the history says of it: its commit's date, the test rows committed by then (per agent),
    and per governed agent its test rows flown by code descending from the choice and those that were not."""

    decision: Decision
    date: str
    visible: dict[str, int] = field(default_factory=dict)
    after: dict[str, int] = field(default_factory=dict)
    before: dict[str, int] = field(default_factory=dict)


@dataclass(frozen=True)
class DecisionLogValues:
    """Every value ``decision_log.md`` words (``templates/decision_log.md.j2``): the suite version, the commit
    that froze it and that commit's date, and each logged choice."""

    command: str
    generated: str
    version: str
    frozen_at: str
    frozen_date: str
    decisions: list[LoggedDecision]


def read_decisions(path: Path = DECISIONS_FILE) -> tuple[str, str, list[Decision]]:
    """The suite version, the commit that froze it and the choices of ``path``.

    Raises:
        ValueError: a file that is not such a log, or a choice without its keys (the message names it).
    """
    content = yaml.safe_load(Path(path).read_text(encoding="utf-8"))
    if not isinstance(content, dict) or not {"suite_version", "frozen_at", "decisions"} <= set(content):
        raise ValueError(f"{path}: expected the keys suite_version, frozen_at and decisions")
    decisions = []
    for entry in content["decisions"]:
        missing = {"id", "chose", "commit", "validation"} - set(entry)
        if missing:
            raise ValueError(f"{path}: decision {entry.get('id', '?')!r} lacks {', '.join(sorted(missing))}")
        decisions.append(
            Decision(
                str(entry["id"]),
                " ".join(str(entry["chose"]).split()),
                str(entry["commit"]),
                str(entry["validation"]),
                tuple(entry.get("governs") or ()),
            )
        )
    return str(content["suite_version"]), str(content["frozen_at"]), decisions


def git(*args: str) -> str:
    """``git args`` in the repository, its output.

    Raises:
        ValueError: git fails (not a checkout with the history, or an unknown commit), with what it said.
    """
    result = subprocess.run(["git", "-C", str(REPO_ROOT), *args], capture_output=True, text=True, check=False)
    if result.returncode != 0:
        raise ValueError(f"git {' '.join(args[:2])}: {result.stderr.strip() or result.returncode}")
    return result.stdout


def is_ancestor(older: str, newer: str) -> bool:
    """Whether commit ``older`` is ``newer`` or one of its ancestors."""
    command = ["git", "-C", str(REPO_ROOT), "merge-base", "--is-ancestor", older, newer]
    return subprocess.run(command, capture_output=True, check=False).returncode == 0


def version_rows(text: str, version: str) -> list[tuple[str, str]]:
    """(agent base name, code version) of each row of suite ``version`` in an episodes CSV's ``text``."""
    reader = csv.DictReader(io.StringIO(text))
    return [
        (base_agent_name(row["agent"]), row.get("code_version") or "")
        for row in reader
        if row.get("suite_version") == version
    ]


def commit_of(code_version: str) -> str:
    """The commit in a row's ``code_version`` (``commit `abc1234` ...``), or "" where it names none."""
    return code_version.partition("`")[2].partition("`")[0]


def log_decisions(
    decisions: Sequence[Decision], version: str, episodes: Sequence[tuple[str, str]]
) -> list[LoggedDecision]:
    """Each choice with what the history says of it; ``episodes`` are today's test rows (agent, code version)."""
    logged = []
    flown_by = Counter(episodes)
    for decision in decisions:
        date = git("log", "-1", "--format=%cd", "--date=format:%Y-%m-%d %H:%M UTC", decision.commit).strip()
        try:
            then = git("show", f"{decision.commit}:{EPISODES}")
        except ValueError:  # the file did not exist yet
            then = ""
        visible = Counter(agent for agent, _ in version_rows(then, version))
        after: Counter[str] = Counter()
        before: Counter[str] = Counter()
        for (agent, code_version), count in flown_by.items():
            if agent not in decision.governs:
                continue
            commit = commit_of(code_version)
            descends = bool(commit) and is_ancestor(decision.commit, commit)
            (after if descends else before)[agent] += count
        logged.append(LoggedDecision(decision, date, dict(visible), dict(after), dict(before)))
    return logged


def write_decision_log(out: Path = RESULTS_DIR, command: str = "flownav decision-log --out results") -> Path:
    """Write ``decision_log.md`` into ``out`` from ``configs/decisions.yaml``, the committed test rows and git."""
    version, frozen_at, decisions = read_decisions()
    episodes = version_rows((REPO_ROOT / EPISODES).read_text(encoding="utf-8"), version)
    logged = log_decisions(decisions, version, episodes)
    frozen_date = git("log", "-1", "--format=%cd", "--date=format:%Y-%m-%d %H:%M UTC", frozen_at).strip()
    values = DecisionLogValues(command, today(), version, frozen_at, frozen_date, logged)
    text = render_report("decision_log.md.j2", values)
    path = Path(out) / PAGE
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    write_decision_rows(Path(out) / DECISION_CSV, agent_decisions(logged))
    return path


def agent_decisions(logged: Sequence[LoggedDecision]) -> list[AgentDecision]:
    """Per governed agent, each logged choice with the test rows visible when it was made (what ``suite.md``
    shows beside the agent)."""
    return [
        AgentDecision(
            agent=agent,
            decision=entry.decision.id,
            commit=entry.decision.commit,
            date=entry.date,
            visible="; ".join(f"{name} {count:,}" for name, count in sorted(entry.visible.items())) or "none",
        )
        for entry in logged
        for agent in entry.decision.governs
    ]
