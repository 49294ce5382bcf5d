"""How the benchmark report words its claims: which agents a factor breaks, lists of names, and the comparisons
of two agents (from a paired test, :mod:`agents.evaluation.paired`), each computed from the data so that a
sentence such as "breaks every agent" is only written when it holds.

The tables here are :func:`agents.studies.error_analysis.tolerance_table`'s rows: one per agent, factor and side
of the neutral level, with the first level at which the agent breaks (``breaking_level``, None where no level
flown breaks it) and the levels flown.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from agents.evaluation import paired
from agents.evaluation.paired import Comparison
from agents.policies.base import base_agent_name

# The lever search's winner, chosen on validation layouts (results/flow_gap.md): the reports call it "the winner".
WINNER = "ppo_flow_course_approach_curriculum_slow"
# The winner's recipe, both stages and the same budget, on the true depths at the same tracked points: the
# true-depth comparison.
WINNER_ON_TRUE_DEPTHS = f"{WINNER}_oracle"


def display_name(agent: str) -> str:
    """How the reports name an agent: its base name in backticks (``ppo_flow@all`` → `` `ppo_flow` ``), and
    the lever search's winner "the winner"."""
    base = base_agent_name(agent)
    return "the winner" if base == WINNER else f"`{base}`"


def join_words(words: Sequence[str], last: str = "and") -> str:
    """``a``; ``a and b``; ``a, b and c`` (``last`` may be "or")."""
    words = list(words)
    if not words:
        return ""
    if len(words) == 1:
        return words[0]
    return f"{', '.join(words[:-1])} {last} {words[-1]}"


def _rows_at(table: Sequence[Mapping[str, Any]], factor: str, level: float) -> list[Mapping[str, Any]]:
    """The rows of ``factor`` on the side of the neutral level that holds ``level``."""
    return [row for row in table if row["factor"] == factor and level in row["levels"]]


def _reached(row: Mapping[str, Any], level: float) -> bool:
    """Whether the row's agent has broken by ``level``: its first breaking level lies at or before ``level``,
    scanning outward from the neutral level (the order of ``row["levels"]``)."""
    if row["breaking_level"] is None:
        return False
    levels = list(row["levels"])
    return levels.index(row["breaking_level"]) <= levels.index(level)


def agents_broken_by(
    table: Sequence[Mapping[str, Any]], factor: str, level: float
) -> tuple[list[str], list[str]]:
    """Which agents ``factor`` has broken by ``level``, and which it has not.

    An agent counts as broken when the first level that breaks it (its failure interval wholly above the clean
    one) lies at or before ``level`` on that side of the neutral level; only agents that flew ``level`` count.

    Args:
        table: tolerance rows (:func:`~agents.studies.error_analysis.tolerance_table`).
        factor: the factor.
        level: one of the levels flown.

    Returns:
        (broken, unbroken): agent names, each in the table's order.

    Raises:
        ValueError: no agent flew ``factor`` at ``level``.
    """
    rows = _rows_at(table, factor, level)
    if not rows:
        raise ValueError(f"no agent in the table flew {factor} at {level:g}")
    broken = [row["agent"] for row in rows if _reached(row, level)]
    unbroken = [row["agent"] for row in rows if not _reached(row, level)]
    return broken, unbroken


def every_or_all_but(members: Sequence[str], chosen: Sequence[str], noun: str = "agent") -> str:
    """Name the ``chosen`` among ``members`` the shortest way that is still exact.

    "every agent" when all are chosen, "no agent" when none is, "all agents but `x`" (or "but `x` and `y`")
    when at most two and fewer than half are left out, else the chosen ones listed, "but not" the others.

    Args:
        members: every name the claim is about (display names, in order).
        chosen: the names for which it holds.
        noun: what the members are, singular.

    Returns:
        The phrase, to follow a verb ("breaks every agent").
    """
    chosen_set = set(chosen)
    left = [name for name in members if name not in chosen_set]
    picked = [name for name in members if name in chosen_set]
    if not left:
        return f"every {noun}"
    if not picked:
        return f"no {noun}"
    if len(left) <= 2 and len(left) < len(picked):
        return f"all {noun}s but {join_words(left)}"
    return f"{join_words(picked)} but not {join_words(left, 'or')}"


def breaks_phrase(table: Sequence[Mapping[str, Any]], factor: str, level: float, noun: str = "agent") -> str:
    """ "every agent" / "all agents but `vfh`" / "`a` and `b` but not `c`": the agents ``factor`` has broken by
    ``level`` (:func:`agents_broken_by`), named with :func:`display_name`."""
    broken, _ = agents_broken_by(table, factor, level)
    members = [display_name(row["agent"]) for row in _rows_at(table, factor, level)]
    return every_or_all_but(members, [display_name(agent) for agent in broken], noun)


def rate(value: float) -> str:
    """A rate as the reports print it: two decimals."""
    return f"{value:.2f}"


def rate_range(values: Sequence[float]) -> str:
    """``0.22–0.50``, or one rate where all round alike."""
    low, high = rate(min(values)), rate(max(values))
    return low if low == high else f"{low}–{high}"


def delta(value: float) -> str:
    """A difference of rates with its sign: ``+0.34``, ``-0.01``."""
    return f"{value:+.2f}"


def interval(point: float, low: float, high: float) -> str:
    """``0.08 [0.06, 0.11]``."""
    return f"{point:.2f} [{low:.2f}, {high:.2f}]"


def difference(comparison: Comparison) -> str:
    """A paired difference of failure rates with its 95 % interval: ``+0.021 [+0.002, +0.038]``."""
    return f"{comparison.difference:+.3f} [{comparison.low:+.3f}, {comparison.high:+.3f}]"


def verdict(comparison: Comparison, agent: str = "", reference: str = "") -> str:
    """:func:`agents.evaluation.paired.verdict` with the two named by ``agent`` and ``reference``, else by
    :func:`display_name`."""
    return paired.verdict(
        comparison, agent or display_name(comparison.agent), reference or display_name(comparison.reference)
    )


def paired_reading(comparison: Comparison) -> str:
    """A comparison of two agents as the reports word it: "paired by layout, the winner − `bee_ttc` = +0.021
    [+0.002, +0.038]: `bee_ttc` fails less than the winner"."""
    agent, reference = display_name(comparison.agent), display_name(comparison.reference)
    return f"paired by layout, {agent} − {reference} = {difference(comparison)}: {verdict(comparison)}"


def level_text(level: float, unit: str = "") -> str:
    """A factor level with its unit: ``0.5°``, ``1.5 m/s``, ``-0.3``."""
    text = f"{level:g}"
    return f"{text}{unit}" if unit.startswith("°") or not unit else f"{text} {unit}"
