"""Does learning beat the rules on a tier? Per tier, the best ranked learned agent against the best ranked rule,
paired by layout (:func:`agents.analysis.paired.compare`: layouts drawn once for both, the learned agent's
training runs drawn on their own).

Only ranked agents take part: a privileged agent reads what the tier's sensor does not give, and a learned
agent with fewer than :data:`~agents.analysis.paired.MIN_RANKED_SEEDS` training seeds describes its runs, not
its recipe. "Best" is the lowest mean failure on the tier's layouts, within each kind.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from agents.analysis.paired import Comparison, TierRanking, compare
from agents.policies.base import REACTIVE_AGENTS, is_learned


@dataclass(frozen=True)
class LearningGain:
    """On ``tier``: the best ranked learned agent against the best ranked rule (difference learned − rule)."""

    tier: str
    learned: str
    rule: str
    learned_failure: float
    rule_failure: float
    comparison: Comparison


def _best(failures: Mapping[str, np.ndarray], names: Sequence[str]) -> str | None:
    present = [name for name in names if name in failures]
    if not present:
        return None
    return min(present, key=lambda name: (float(np.mean(failures[name])), name))


def learning_gain(tier: str, failures: Mapping[str, np.ndarray], ranking: TierRanking) -> LearningGain | None:
    """The best ranked learned agent against the best ranked rule on ``tier``, from its failure matrices
    (runs, layouts) and its :class:`~agents.analysis.paired.TierRanking`; None where either kind has no ranked
    agent."""
    ranked = [ranking.best, *(c.agent for c in ranking.comparisons)]
    learned = _best(failures, [name for name in ranked if is_learned(name)])
    rule = _best(failures, [name for name in ranked if name in REACTIVE_AGENTS])
    if learned is None or rule is None:
        return None
    comparison = compare(learned, failures[learned], rule, failures[rule])
    return LearningGain(
        tier,
        learned,
        rule,
        float(np.mean(failures[learned])),
        float(np.mean(failures[rule])),
        comparison,
    )


def learning_gains(
    failures: Mapping[str, Mapping[str, np.ndarray]], rankings: Mapping[str, TierRanking]
) -> list[LearningGain]:
    """:func:`learning_gain` for every ranked tier of ``failures`` (tier → agent → matrix), in their order."""
    gains = []
    for tier, ranking in rankings.items():
        gain = learning_gain(tier, failures[tier], ranking)
        if gain is not None:
            gains.append(gain)
    return gains
