"""The agents the benchmark knows by name and their kinds, read from ``configs/agents.yaml`` (the one place they
are written), and how a run of a learned agent's training seed is named (``ppo_flow@3``).

Pure: it imports no policy, no env, no simulator, so the analysis of committed records can read it.
"""

from __future__ import annotations

import difflib
import unicodedata
from dataclasses import dataclass
from pathlib import Path
from typing import Literal, get_args

import yaml

from agents.common.locations import CONFIGS_DIR

AGENTS_FILE = CONFIGS_DIR / "agents.yaml"
Kind = Literal["rule", "learned", "planner"]
Sight = Literal["flow", "nothing", "true_depth", "layout", "camera_view"]
# What a privileged agent sees beyond what a tier's sensor gives.
PRIVILEGED_SIGHTS: tuple[Sight, ...] = ("true_depth", "layout", "camera_view")
# A learned agent's training seed k is named "<agent>@<k>" (ppo_flow@3): its policy is
# results/policies/<agent>/seed_<k>.zip, and episode records keep the seeds apart by name.
TRAIN_SEED_MARK = "@"


@dataclass(frozen=True)
class AgentEntry:
    """One agent of ``configs/agents.yaml``: its name, kind, what it sees, and its place in the suite."""

    name: str
    kind: Kind
    sees: Sight
    suite_only: bool = False
    per_tier: bool = False
    retired: str = ""
    # (suite version, why) for each suite version the suite does not fly this agent on.
    not_flown_on: tuple[tuple[str, str], ...] = ()

    @property
    def privileged(self) -> bool:
        """Whether it reads what a tier's sensor does not give (a reference, never ranked)."""
        return self.sees in PRIVILEGED_SIGHTS


def read_agent_table(path: Path = AGENTS_FILE) -> tuple[AgentEntry, ...]:
    """The agents of ``path``, in its order.

    Raises:
        ValueError: an entry with an unknown key, kind or sight (the message names the agent, the value and the
            allowed ones).
    """
    entries = yaml.safe_load(path.read_text(encoding="utf-8"))["agents"]
    table = []
    for name, values in entries.items():
        unknown = set(values) - {"kind", "sees", "suite_only", "per_tier", "retired", "not_flown_on"}
        if unknown:
            raise ValueError(f"{path}: agent {name!r} has unknown keys {sorted(unknown)}")
        values = {**values, "not_flown_on": _not_flown_on(path, str(name), values.get("not_flown_on", {}))}
        for key, allowed in (("kind", get_args(Kind)), ("sees", get_args(Sight))):
            if values.get(key) not in allowed:
                raise ValueError(
                    f"{path}: agent {name!r} {key} must be one of {', '.join(allowed)}, got {values.get(key)!r}"
                )
        if values.get("per_tier") and values["kind"] != "learned":
            raise ValueError(f"{path}: agent {name!r} is per_tier, which only a learned agent can be")
        table.append(AgentEntry(name=str(name), **values))
    return tuple(table)


def _not_flown_on(path: Path, name: str, versions: object) -> tuple[tuple[str, str], ...]:
    """An entry's ``not_flown_on``: suite version (as written in quotes, ``"2"``) → why, each why a sentence."""
    if not isinstance(versions, dict) or not all(
        isinstance(version, str) and version.isdigit() and isinstance(why, str) and why.strip()
        for version, why in versions.items()
    ):
        raise ValueError(
            f'{path}: agent {name!r} not_flown_on must map suite versions (quoted, such as "2") to why, got '
            f"{versions!r}"
        )
    return tuple(sorted(versions.items()))


AGENT_TABLE = read_agent_table()
AGENTS = {entry.name: entry for entry in AGENT_TABLE}


def agents_where(*, kind: Kind | None = None, privileged: bool | None = None) -> tuple[str, ...]:
    """The names of the agents of ``kind`` (any when None), privileged or not (either when None), in order."""
    return tuple(
        entry.name
        for entry in AGENT_TABLE
        if (kind is None or entry.kind == kind) and (privileged is None or entry.privileged == privileged)
    )


def kind_of(name: str) -> Kind | None:
    """The kind of the agent a run name belongs to (``ppo_flow@3`` → learned); None for one not in the table
    (an outside agent, an experiment's recipe). Not validated, as :func:`base_agent_name`."""
    entry = AGENTS.get(base_agent_name(name))
    return None if entry is None else entry.kind


def is_per_tier(name: str) -> bool:
    """Whether the agent a run name belongs to is learned once per tier (``per_tier`` in the table): on tier
    ``<tier>`` it flies the policies of ``<agent>_<tier>``. Not validated, as :func:`base_agent_name`."""
    entry = AGENTS.get(base_agent_name(name))
    return entry is not None and entry.per_tier


def base_agent_name(name: str) -> str:
    """The agent a run name belongs to, whatever follows the seed mark: ``ppo_flow@3`` and the sweep's pooled
    ``ppo_flow@all`` → ``ppo_flow``; ``bee`` → ``bee``. Not validated (see :func:`split_agent_name`)."""
    return str(name).partition(TRAIN_SEED_MARK)[0]


def seeded_agent_name(agent: str, train_seed: int) -> str:
    """The name of training seed ``train_seed`` of the learned ``agent``: ``ppo_flow@3``."""
    return f"{agent}{TRAIN_SEED_MARK}{train_seed}"


def split_agent_name(name: str) -> tuple[str, int | None]:
    """``"ppo_flow@3"`` → ``("ppo_flow", 3)``; ``"bee"`` → ``("bee", None)``; an outside agent
    (``my_module:make_agent``) → itself and None.

    Raises:
        ValueError: an unknown agent, a training seed on an agent that is not learned, or a seed that is not an
            integer >= 0.
    """
    if ":" in str(name):  # written outside FlowNav (agents.policies.external)
        return str(name), None
    base, mark, seed_text = str(name).partition(TRAIN_SEED_MARK)
    allowed = (
        f"one of {', '.join(AGENTS)}, <learned agent>@<training seed> such as ppo_flow@0, or an agent "
        "of your own as module.path:callable or path/to/file.py:callable"
    )
    if base not in AGENTS:
        close = difflib.get_close_matches(base, list(AGENTS), n=1)
        raise ValueError(
            f"agent must be {allowed}, got {name!r}" + (f"; did you mean {close[0]!r}?" if close else "")
        )
    if not mark:
        return base, None
    if AGENTS[base].kind != "learned":
        learned = agents_where(kind="learned")
        raise ValueError(f"only learned agents have training seeds ({', '.join(learned)}), got {name!r}")
    if not seed_text.isdigit():
        raise ValueError(f"a training seed must be an integer >= 0, got {name!r}")
    return base, int(seed_text)


def is_learned(name: str) -> bool:
    """Whether ``name`` (with or without a training seed) is a learned agent.

    Raises:
        ValueError: as :func:`split_agent_name`.
    """
    base = split_agent_name(name)[0]
    return base in AGENTS and AGENTS[base].kind == "learned"


def name_key(name: str) -> str:
    """``name`` as a person reads it: NFKC-normalised, casefolded, with whitespace and invisible (format)
    characters such as U+200B left out; two names with the same key look alike."""
    text = unicodedata.normalize("NFKC", str(name))
    return "".join(ch for ch in text if not ch.isspace() and unicodedata.category(ch) != "Cf").casefold()


def published_name_like(name: str) -> str | None:
    """The agent of ``configs/agents.yaml`` whose name ``name`` reads as (``Bee_Robust``, ``bee_robust `` and
    ``bee_robust`` + U+200B all read as ``bee_robust``; so does a training seed of it, ``bee_robust@1``), or None
    where it reads as none."""
    key = name_key(name)
    base = key.partition(TRAIN_SEED_MARK)[0]
    return next((entry.name for entry in AGENT_TABLE if name_key(entry.name) in (key, base)), None)
