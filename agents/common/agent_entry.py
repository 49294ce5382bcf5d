"""One agent's declaration, as ``configs/agents.yaml`` writes it (or :func:`~agents.common.agent_table.register_agent`
takes it): what it is (kind, what it sees, its place in the suite) and, for an agent built from code (a rule, a
planner), the class it is built from, the env settings it asks for and the space its gains are tuned over.

Checked here as data only: the class is named, not imported (this bottom layer imports no policy); the policies
layer (:mod:`agents.policies.registry`) imports it and checks the search space against its fields.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal, cast, get_args

Kind = Literal["rule", "learned", "planner"]
Sight = Literal["flow", "nothing", "true_depth", "layout", "camera_view"]
# What a privileged agent sees beyond what a tier's sensor gives.
PRIVILEGED_SIGHTS: tuple[Sight, ...] = ("true_depth", "layout", "camera_view")
# A searched gain's (low, high, log scale); an integer field is searched over the integers.
SearchRange = tuple[float, float, bool]
# How a search range's third item is written: "log" or "linear".
SEARCH_SCALES = {"log": True, "linear": False}
# The value types an env setting an agent asks for may have (the env's observe_* switches are booleans; the
# histogram's sectors and bin edges are tuples of numbers).
EnvValue = bool | int | float | str | tuple[int | float, ...]
# "package.module:ClassName": where an agent built from code is written.
CLASS_PATH = re.compile(r"^[A-Za-z_][\w.]*:[A-Za-z_]\w*$")
TABLE_KEYS = ("kind", "sees", "suite_only", "per_tier", "retired", "not_flown_on")
CODE_KEYS = ("class", "env", "search_space", "fixed_gains")


@dataclass(frozen=True)
class AgentEntry:
    """One declared agent: its name, kind, what it sees, its place in the suite, and for a rule or a planner how
    it is built (the table's comment in ``configs/agents.yaml`` says what each key means)."""

    name: str
    kind: Kind
    sees: Sight
    suite_only: bool = False
    per_tier: bool = False
    retired: str = ""
    # (suite version, why) for each suite version the suite does not fly this agent on.
    not_flown_on: tuple[tuple[str, str], ...] = ()
    # "package.module:ClassName", a dataclass of its gains; empty for a learned agent (its policy is a file).
    class_path: str = ""
    # The env settings it asks for beyond the env's defaults (the runner adds them to every cell).
    env: tuple[tuple[str, EnvValue], ...] = ()
    # Its gains' search space in order, for `flownav tune`; None where it is not tuned.
    search_space: tuple[tuple[str, SearchRange], ...] | None = None
    # Flies its defaults whatever gains a caller passes (the straight flight: its gains only hold its height).
    fixed_gains: bool = False

    @property
    def privileged(self) -> bool:
        """Whether it reads what a tier's sensor does not give (a reference, never ranked)."""
        return self.sees in PRIVILEGED_SIGHTS

    @property
    def tunable(self) -> bool:
        """Whether it has a search space (``flownav tune`` takes it)."""
        return self.search_space is not None


def agent_entry(source: str, name: str, values: Mapping[str, object]) -> AgentEntry:
    """The entry ``name: values`` of ``source`` (the table's file, or ``register_agent``), checked.

    Raises:
        ValueError: an unknown key, kind or sight, a per-tier agent that is not learned, a bad ``not_flown_on``,
            or a rule or planner without a class (or a learned agent with code keys); the message names
            ``source``, the agent, the value and the allowed ones.
    """
    unknown = set(values) - {*TABLE_KEYS, *CODE_KEYS}
    if unknown:
        raise ValueError(f"{source}: agent {name!r} has unknown keys {sorted(unknown)}")
    for key, allowed in (("kind", get_args(Kind)), ("sees", get_args(Sight))):
        if values.get(key) not in allowed:
            raise ValueError(
                f"{source}: agent {name!r} {key} must be one of {', '.join(allowed)}, got {values.get(key)!r}"
            )
    if values.get("per_tier") and values["kind"] != "learned":
        raise ValueError(f"{source}: agent {name!r} is per_tier, which only a learned agent can be")
    entry = AgentEntry(
        name=name,
        kind=cast("Kind", values["kind"]),
        sees=cast("Sight", values["sees"]),
        suite_only=bool(values.get("suite_only", False)),
        per_tier=bool(values.get("per_tier", False)),
        retired=str(values.get("retired", "")),
        not_flown_on=_not_flown_on(source, name, values.get("not_flown_on", {})),
    )
    return _with_code(source, entry, values)


def _not_flown_on(source: str, name: str, versions: object) -> tuple[tuple[str, str], ...]:
    """An entry's ``not_flown_on``: suite version (as written in quotes, ``"2"``) → why, each why a sentence."""
    if not isinstance(versions, dict) or not all(
        isinstance(version, str) and version.isdigit() and isinstance(why, str) and why.strip()
        for version, why in versions.items()
    ):
        raise ValueError(
            f'{source}: agent {name!r} not_flown_on must map suite versions (quoted, such as "2") to why, got '
            f"{versions!r}"
        )
    return tuple(sorted(versions.items()))


def _with_code(source: str, entry: AgentEntry, values: Mapping[str, object]) -> AgentEntry:
    """``entry`` with its code keys from ``values``: a learned agent has none, a rule or planner a class."""
    name = entry.name
    written = [key for key in CODE_KEYS if key in values]
    if entry.kind == "learned":
        if written:
            raise ValueError(
                f"{source}: agent {name!r} is learned (its policy is a file), so it takes none of "
                f"{', '.join(CODE_KEYS)}, got {', '.join(written)}"
            )
        return entry
    class_path = values.get("class")
    if not isinstance(class_path, str) or not CLASS_PATH.match(class_path):
        raise ValueError(
            f"{source}: agent {name!r} is a {values['kind']}, so its class must be written "
            f"package.module:ClassName, got {class_path!r}"
        )
    fixed_gains = values.get("fixed_gains", False)
    if not isinstance(fixed_gains, bool):
        raise ValueError(f"{source}: agent {name!r} fixed_gains must be true or false, got {fixed_gains!r}")
    space = values.get("search_space")
    return dataclasses.replace(
        entry,
        class_path=class_path,
        env=_env(source, name, values.get("env", {})),
        search_space=None if space is None else _search_space(source, name, space),
        fixed_gains=fixed_gains,
    )


def _env(source: str, name: str, settings: object) -> tuple[tuple[str, EnvValue], ...]:
    """An entry's ``env``: env setting → value (a list of numbers, such as a histogram's sectors or bin edges, as a
    tuple), in order."""
    if not isinstance(settings, dict) or not all(
        isinstance(key, str) and _is_env_value(value) for key, value in settings.items()
    ):
        raise ValueError(
            f"{source}: agent {name!r} env must map env settings to values (such as observe_unresolved: true), "
            f"got {settings!r}"
        )
    return tuple((key, tuple(value) if isinstance(value, list) else value) for key, value in settings.items())


def _is_env_value(value: object) -> bool:
    """A scalar setting, or a non-empty list of numbers (booleans are not numbers here)."""
    if isinstance(value, list):
        return bool(value) and all(
            isinstance(item, (int, float)) and not isinstance(item, bool) for item in value
        )
    return isinstance(value, (bool, int, float, str))


def _search_space(source: str, name: str, space: object) -> tuple[tuple[str, SearchRange], ...]:
    """An entry's ``search_space``: gain → [low, high, log or linear], low < high, in order (the order the
    search draws them in)."""
    if not isinstance(space, dict) or not space:
        raise ValueError(
            f"{source}: agent {name!r} search_space must map gains to [low, high, log or linear], got {space!r}"
        )
    ranges = []
    for gain, written in space.items():
        if not (
            isinstance(written, list)
            and len(written) == 3
            and all(isinstance(bound, int | float) and not isinstance(bound, bool) for bound in written[:2])
            and written[0] < written[1]
            and written[2] in SEARCH_SCALES
        ):
            raise ValueError(
                f"{source}: agent {name!r} search_space {gain} must be [low, high, log or linear] with "
                f"low < high, got {written!r}"
            )
        low, high = cast(
            "tuple[float, float]", tuple(written[:2])
        )  # ints stay ints: an integer gain's bounds
        ranges.append((str(gain), (low, high, SEARCH_SCALES[written[2]])))
    return tuple(ranges)
