"""What ``suite.md`` finds beyond its tables, as its template takes it: the learning gains, the chains of
references, the page's secondary comparisons corrected as one family, and the logged choices behind each agent.
The ranking in the tables has its own correction (:mod:`agents.analysis.paired`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from agents.analysis.decision_rows import AgentDecision
from agents.analysis.family import FamilyCorrection, correct_family
from agents.evaluation.learning_gain import LearningGain
from agents.evaluation.reference_chain import ChainLink
from agents.evaluation.tier_bound import TierBound


@dataclass(frozen=True)
class SuiteFindings:
    """The page's findings beyond its tables (:func:`findings`): the learning gains, the chains that hold more
    than one link, the secondary comparisons as one family, and the logged choices per agent."""

    gains: list[LearningGain]
    chains: dict[str, list[ChainLink]]
    secondary: FamilyCorrection
    decisions: dict[str, list[AgentDecision]]


def findings(
    bounds: Mapping[str, TierBound],
    chains: Mapping[str, Sequence[ChainLink]],
    gains: Sequence[LearningGain],
    decisions: Mapping[str, Sequence[AgentDecision]],
) -> SuiteFindings:
    """The page's findings beyond its tables, as ``suite.md`` words them."""
    return SuiteFindings(
        gains=list(gains),
        chains={name: list(links) for name, links in chains.items() if len(links) > 1},
        secondary=secondary_family(bounds, chains, gains),
        decisions={agent: list(rows) for agent, rows in decisions.items()},
    )


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
