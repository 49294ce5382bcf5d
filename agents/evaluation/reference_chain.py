"""From the map to flow, per tier: what each step of sensing costs, paired by layout.

The chain's links, each knowing less than the one before (:data:`CHAIN`):

1. the map: ``planner`` knows every capsule and its true state;
2. the camera's view: ``planner_camera`` knows only the capsules that have been in view within its range;
3. the observation's resolution: ``planner_camera_observed`` knows them only as the histogram resolves them, at
   each resolution declared for it (the default 3 × 5, the camera student's 3 × 15, a finer 1 × 32), or with the
   histogram integrated over frames (``planner_camera_filtered``): the best flown is the link, its resolution
   named;
4. true depths, learned: the best learned agent that reads true depths (a privileged twin);
5. flow, learned: the best learned agent on the estimator's depths;
6. flow, a rule: the best reactive rule.

Each link's cost is its failure minus the previous flown link's, on the same layouts (:func:`~agents.evaluation.
paired.compare`: layouts drawn once for both, a learned agent's training runs on their own). A link not flown on a
tier is left out, and the next one is measured from the last that was.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from agents.analysis.paired import Comparison, compare, provisional_note
from agents.policies import REACTIVE_AGENTS, is_learned, is_privileged
from agents.policies.base import PLANNERS
from agents.policies.planner_camera import ObservedCameraPlannerAgent
from agents.policies.planner_camera_filtered import FilteredCameraPlannerAgent
from agents.policies.registry import planner_class, requested_env_kwargs
from flownav_env.settings import EnvSettings


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


# The map's reference and the camera-limited one (what the camera's view allows, the bar a learned flow agent is
# held to).
MAP_REFERENCE, CAMERA_VIEW_REFERENCE = PLANNERS[0], PLANNERS[1]
# The observation-limited references: the camera-limited planner shown only what a histogram resolves, one per
# resolution declared (configs/agents.yaml); the chain's link is the best of those flown, its resolution named.
OBSERVED_REFERENCES = tuple(
    name for name in PLANNERS if issubclass(planner_class(name), ObservedCameraPlannerAgent)
)
OBSERVATION_LINK = "the observation's resolution"


def _only(name: str) -> Callable[[Mapping[str, np.ndarray]], str | None]:
    return lambda failures: name if name in failures else None


# Each link: what its agent knows, and how it is picked among the agents flown on the tier.
CHAIN: Sequence[tuple[str, Callable[[Mapping[str, np.ndarray]], str | None]]] = (
    ("the map", _only(MAP_REFERENCE)),
    ("the camera's view", _only(CAMERA_VIEW_REFERENCE)),
    (OBSERVATION_LINK, lambda f: _best(f, lambda name: name in OBSERVED_REFERENCES)),
    ("true depths, learned", lambda f: _best(f, _learned_on_true_depths)),
    ("flow, learned", lambda f: _best(f, _learned_on_flow)),
    ("flow, a rule", lambda f: _best(f, lambda name: name in REACTIVE_AGENTS)),
)


def resolution_text(agent: str) -> str:
    """The histogram resolution an observation-limited reference plans on, in words: "3 × 15 sectors, bins 0.5 m
    wide from 0" (its declared settings over the env's defaults)."""
    settings = {**dataclasses.asdict(EnvSettings()), **requested_env_kwargs(agent)}
    rows, cols = settings["histogram_sectors"]
    edges = settings["depth_bin_edges"]
    over_frames = issubclass(planner_class(agent), FilteredCameraPlannerAgent)
    return f"{rows} × {cols} sectors, bins {edges[1] - edges[0]:g} m wide from {edges[0]:g}" + (
        ", integrated over frames" if over_frames else ""
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
        named = f"{knows} ({resolution_text(agent)})" if knows == OBSERVATION_LINK else knows
        links.append(ChainLink(named, agent, float(np.mean(failures[agent])), cost))
        previous = agent
    return links
