"""From the map to flow, per tier: what each step of sensing costs, paired by layout.

The chain's links, each knowing less than the one before (:data:`CHAIN`):

1. the map: ``planner`` knows every capsule and its true state;
2. the camera's view: ``planner_camera`` knows only the capsules that have been in view within its range;
3. the observation's resolution: ``planner_camera_observed`` knows them only as the histogram resolves them;
4. true depths, learned: the best learned agent that reads true depths (a privileged twin);
5. flow, learned: the best learned agent on the estimator's depths;
6. flow, a rule: the best reactive rule.

Each link's cost is its failure minus the previous flown link's, on the same layouts (:func:`~agents.evaluation.
paired.compare`: layouts drawn once for both, a learned agent's training runs on their own). A link not flown on a
tier is left out, and the next one is measured from the last that was.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from agents.analysis.paired import Comparison, compare, provisional_note
from agents.policies import REACTIVE_AGENTS, is_learned, is_privileged
from agents.policies.base import PLANNERS


@dataclass(frozen=True)
class ChainLink:
    """One flown link of a tier's chain: what it knows, the agent, its failure, and its cost over the previous
    flown link (None for the first)."""

    knows: str
    agent: str
    failure: float
    cost: Comparison | None

    @property
    def provisional(self) -> str:
        """The mark of a cost that rests on a learned agent with fewer training seeds than a ranked one needs
        (``"; provisional: ..."``), on either side; empty otherwise."""
        return "" if self.cost is None else provisional_note(self.cost)


def _best(failures: Mapping[str, np.ndarray], keep: Callable[[str], bool]) -> str | None:
    present = sorted(name for name in failures if keep(name))
    return min(present, key=lambda name: float(np.mean(failures[name])), default=None)


def _learned(name: str, privileged: bool) -> bool:
    """Whether ``name`` is a published learned agent reading true depths (``privileged``) or flow; an agent from
    outside FlowNav is neither: its kind is not known here."""
    try:
        return is_learned(name) and is_privileged(name) == privileged
    except ValueError:
        return False


def _learned_on_true_depths(name: str) -> bool:
    return _learned(name, privileged=True)


def _learned_on_flow(name: str) -> bool:
    return _learned(name, privileged=False)


# The camera-limited reference: what the camera's view allows, the bar a learned flow agent is held to.
CAMERA_VIEW_REFERENCE = PLANNERS[1]

# Each link: what its agent knows, and how it is picked among the agents flown on the tier.
CHAIN: Sequence[tuple[str, Callable[[Mapping[str, np.ndarray]], str | None]]] = (
    *(
        (knows, lambda f, name=name: name if name in f else None)
        for knows, name in zip(
            ("the map", "the camera's view", "the observation's resolution"), PLANNERS, strict=True
        )
    ),
    ("true depths, learned", lambda f: _best(f, _learned_on_true_depths)),
    ("flow, learned", lambda f: _best(f, _learned_on_flow)),
    ("flow, a rule", lambda f: _best(f, lambda name: name in REACTIVE_AGENTS)),
)


def reference_chain(failures: Mapping[str, np.ndarray]) -> list[ChainLink]:
    """The tier's chain from its agents' failure matrices (runs, layouts on the same layouts): the links flown,
    in :data:`CHAIN` order, each with its cost over the previous flown link."""
    links: list[ChainLink] = []
    previous: str | None = None
    for knows, pick in CHAIN:
        agent = pick(failures)
        if agent is None:
            continue
        cost = None if previous is None else compare(agent, failures[agent], previous, failures[previous])
        links.append(ChainLink(knows, agent, float(np.mean(failures[agent])), cost))
        previous = agent
    return links
