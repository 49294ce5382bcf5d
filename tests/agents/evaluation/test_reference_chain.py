"""The chain of references from the map to flow: links in order, each costed over the last flown one."""

from __future__ import annotations

import numpy as np
import pytest

from agents.evaluation.reference_chain import reference_chain


def _failures(*values: int) -> np.ndarray:
    return np.asarray(values, float)[None, :]


def test_the_links_come_in_order_and_each_costs_over_the_last_flown_one() -> None:
    failures = {
        "bee_ttc": _failures(1, 1, 0, 0, 0, 0, 0, 0, 0, 0),
        "planner": _failures(0, 0, 0, 0, 0, 0, 0, 0, 0, 0),
        "planner_camera": _failures(1, 0, 0, 0, 0, 0, 0, 0, 0, 0),
        "bee": _failures(1, 1, 1, 1, 0, 0, 0, 0, 0, 0),
        "ppo_flow": np.vstack([_failures(1, 1, 1, 0, 0, 0, 0, 0, 0, 0)] * 3),
    }
    links = reference_chain(failures)
    assert [(link.knows, link.agent) for link in links] == [
        ("the map", "planner"),
        ("the camera's view", "planner_camera"),
        ("flow, learned", "ppo_flow"),
        ("flow, a rule", "bee_ttc"),  # the best rule, not bee
    ]
    assert links[0].cost is None
    assert links[1].cost.reference == "planner" and links[1].cost.difference == pytest.approx(0.1)
    # The observation's resolution and true depths are not flown: flow is costed over the camera's view.
    assert links[2].cost.reference == "planner_camera" and links[2].cost.difference == pytest.approx(0.2)
    assert links[3].failure == pytest.approx(0.2) and links[3].cost.difference == pytest.approx(-0.1)


def test_a_tier_with_nothing_of_the_chain_flown_has_no_links() -> None:
    assert reference_chain({"someone_else": _failures(0, 1)}) == []


def test_the_observations_link_is_the_best_resolution_flown_and_names_it() -> None:
    failures = {
        "planner_camera": _failures(0, 0, 0, 0),
        "planner_camera_observed": _failures(1, 1, 1, 0),  # the default 3 × 5
        "planner_camera_observed_3x15": _failures(1, 0, 0, 0),
        "planner_camera_observed_1x32": _failures(1, 1, 0, 0),
    }
    _, observed = reference_chain(failures)
    assert observed.agent == "planner_camera_observed_3x15"
    assert observed.knows == "the observation's resolution (3 × 15 sectors, bins 0.5 m wide from 0)"
    (default,) = reference_chain({"planner_camera_observed": _failures(1, 0)})
    assert default.knows == "the observation's resolution (3 × 5 sectors, bins 1 m wide from 0)"
