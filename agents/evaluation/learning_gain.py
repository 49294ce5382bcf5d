"""Does learning beat the rules on a tier? Per tier, the best ranked learned agent against the best ranked rule,
paired by layout (:func:`agents.analysis.paired.compare`: layouts drawn once for both, the learned agent's
training runs drawn on their own).

Only ranked agents take part: a privileged agent reads what the tier's sensor does not give, and a learned
agent with fewer than :data:`~agents.analysis.paired.MIN_RANKED_SEEDS` training seeds describes its runs, not
its recipe. "Best" is the lowest mean failure on the tier's layouts, within each kind. The learned agent is also set against
what the camera allows (the camera-limited reference, :data:`~agents.evaluation.reference_chain.
CAMERA_VIEW_REFERENCE`), where that reference flew the tier.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from agents.analysis.paired import Comparison, TierRanking, compare
from agents.common.agent_table import kind_of
from agents.evaluation.reference_chain import CAMERA_VIEW_REFERENCE
from agents.policies.base import REACTIVE_AGENTS

# How close to the camera-limited reference a learned flow agent should come on every tier: the benchmark's
# stated goal for learning from the camera, judged by the whole interval of the difference.
CAMERA_MARGIN = 0.10


@dataclass(frozen=True)
class LearningGain:
    """On ``tier``: the best ranked learned agent against the best ranked rule (difference learned − rule)."""

    tier: str
    learned: str
    rule: str
    learned_failure: float
    rule_failure: float
    comparison: Comparison
    # learned − the camera-limited reference, paired by layout; None where that reference did not fly the tier.
    camera: Comparison | None = None

    @property
    def within_camera_margin(self) -> bool | None:
        """Whether the learned agent fails at most :data:`CAMERA_MARGIN` more than the camera-limited reference
        (the whole interval at or below it); None where the reference did not fly."""
        return None if self.camera is None else self.camera.high <= CAMERA_MARGIN


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
    # kind_of, not is_learned: an included outside agent's name need not be a FlowNav agent's (its kind is unknown).
    learned = _best(failures, [name for name in ranked if kind_of(name) == "learned"])
    rule = _best(failures, [name for name in ranked if name in REACTIVE_AGENTS])
    if learned is None or rule is None:
        return None
    comparison = compare(learned, failures[learned], rule, failures[rule])
    camera = (
        compare(learned, failures[learned], CAMERA_VIEW_REFERENCE, failures[CAMERA_VIEW_REFERENCE])
        if CAMERA_VIEW_REFERENCE in failures
        else None
    )
    return LearningGain(
        tier,
        learned,
        rule,
        float(np.mean(failures[learned])),
        float(np.mean(failures[rule])),
        comparison,
        camera,
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
