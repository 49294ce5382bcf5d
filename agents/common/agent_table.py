"""The agents the benchmark knows by name and their kinds, read from ``configs/agents.yaml`` (the one place they
are written), and how a run of a learned agent's training seed is named (``ppo_flow@3``).

Pure: it imports no policy, no env, no simulator, so the analysis of committed records can read it.
"""

from __future__ import annotations

import difflib
import unicodedata
from collections.abc import Mapping
from pathlib import Path

import yaml

from agents.common.agent_entry import PRIVILEGED_SIGHTS, AgentEntry, Kind, Sight, agent_entry
from agents.common.locations import CONFIGS_DIR

__all__ = [
    "AGENTS",
    "AGENTS_FILE",
    "AGENT_TABLE",
    "PRIVILEGED_SIGHTS",
    "TRAIN_SEED_MARK",
    "AgentEntry",
    "Kind",
    "Sight",
    "agents_where",
    "base_agent_name",
    "is_learned",
    "is_per_tier",
    "kind_of",
    "name_key",
    "published_name_like",
    "read_agent_table",
    "register_agent",
    "seeded_agent_name",
    "split_agent_name",
    "unregister_agent",
]

AGENTS_FILE = CONFIGS_DIR / "agents.yaml"
# A learned agent's training seed k is named "<agent>@<k>" (ppo_flow@3): its policy is
# results/policies/<agent>/seed_<k>.zip, and episode records keep the seeds apart by name.
TRAIN_SEED_MARK = "@"


def read_agent_table(path: Path = AGENTS_FILE) -> tuple[AgentEntry, ...]:
    """The agents of ``path``, in its order.

    Raises:
        ValueError: an entry with an unknown key, kind or sight, or bad code keys (the message names the agent,
            the value and the allowed ones; :func:`~agents.common.agent_entry.agent_entry`).
    """
    entries = yaml.safe_load(path.read_text(encoding="utf-8"))["agents"]
    return tuple(agent_entry(str(path), str(name), values) for name, values in entries.items())


# The shipped agents, in configs/agents.yaml's order.
AGENT_TABLE = read_agent_table()
# Every declared agent by name: the shipped ones, then any registered since (register_agent).
AGENTS = {entry.name: entry for entry in AGENT_TABLE}


def register_agent(name: str, values: Mapping[str, object]) -> AgentEntry:
    """Declare the agent ``name`` in this process as ``configs/agents.yaml`` would (``values`` are an entry's
    keys: ``{"kind": "rule", "sees": "flow", "class": "my_module:MyRule", ...}``): every name-to-class map, the
    env settings it asks for and the tunable agents are read from :data:`AGENTS`, so it can be flown, tuned and
    ranked at once. The module-level name tuples of :mod:`agents.policies.base` (the suite's agents, the
    history's) are the shipped table's and leave it out; so do worker processes, which re-import the table: fly
    it in this process (``workers=1``).

    Raises:
        ValueError: a name already declared, or a bad entry (as :func:`read_agent_table`).
    """
    if name in AGENTS:
        raise ValueError(f"agent {name!r} is already declared; declared agents: {', '.join(AGENTS)}")
    entry = agent_entry("register_agent", name, values)
    AGENTS[name] = entry
    return entry


def unregister_agent(name: str) -> None:
    """Take back an agent :func:`register_agent` declared.

    Raises:
        ValueError: ``name`` is a shipped agent of ``configs/agents.yaml``, or was never registered.
    """
    registered = [agent for agent in AGENTS if agent not in {entry.name for entry in AGENT_TABLE}]
    if name not in registered:
        raise ValueError(
            f"only an agent declared with register_agent can be unregistered ({', '.join(registered) or 'none'}), "
            f"got {name!r}"
        )
    del AGENTS[name]


def agents_where(
    *, kind: Kind | None = None, privileged: bool | None = None, tunable: bool | None = None
) -> tuple[str, ...]:
    """The names of the declared agents of ``kind`` (any when None), privileged or not, tunable or not (either
    when None), in order."""
    return tuple(
        entry.name
        for entry in AGENTS.values()
        if (kind is None or entry.kind == kind)
        and (privileged is None or entry.privileged == privileged)
        and (tunable is None or entry.tunable == tunable)
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
    return next((agent for agent in AGENTS if name_key(agent) in (key, base)), None)
