"""``suite.md``'s secondary comparisons beyond its tables (what each tier allows, the chains of references, the
learning gains) corrected as one family. The ranking in the tables has its own correction
(:mod:`agents.analysis.paired`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from agents.analysis.family import FamilyCorrection, correct_family
from agents.evaluation.learning_gain import LearningGain
from agents.evaluation.reference_chain import ChainLink
from agents.evaluation.tier_bound import TierBound


def secondary_family(
    bounds: Mapping[str, TierBound], chains: Mapping[str, Sequence[ChainLink]], gains: Sequence[LearningGain]
) -> FamilyCorrection:
    """The page's secondary comparisons (what each tier allows, the chain's steps, learning against the rules and
    against the camera-limited reference) corrected as one family; the ranking has its own correction."""
    family = [(f"`{name}`: best − planner", bound["gap"]) for name, bound in bounds.items()]
    family += [
        (f"`{name}`: {link.knows}", link.cost)
        for name, links in chains.items()
        if len(links) > 1
        for link in links
        if link.cost is not None
    ]
    for gain in gains:
        family.append((f"`{gain.tier}`: learned − rule", gain.comparison))
        if gain.camera is not None:
            family.append((f"`{gain.tier}`: learned − camera-limited reference", gain.camera))
    return correct_family(family)
