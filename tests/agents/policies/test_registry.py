"""The agents built from code are declared once (configs/agents.yaml, or register_agent): every name-to-class
map, the env settings each asks for and the tunable agents are read from the declarations, and a bad one is
refused with a one-line error naming the bad value and the allowed ones."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator

import pytest
from toy_agents import TOY_DECLARATION, ToyRule, declared_agent, declared_toy_rule

from agents.common.agent_table import AGENT_TABLE, AGENTS, agents_where, register_agent, unregister_agent
from agents.policies import agent_env_kwargs, agent_parameters, is_privileged, load_agent
from agents.policies.base import PLANNERS, REACTIVE_AGENTS
from agents.policies.planner import PlannerAgent
from agents.policies.registry import (
    agent_class,
    built_agents,
    planner_class,
    requested_env_kwargs,
    search_space,
    tunable_agents,
)
from agents.studies.tuning_study import check_agent, default_params
from flownav_env.settings import SETTING_NAMES


@pytest.fixture
def toy_rule() -> Iterator[str]:
    yield from declared_toy_rule()


def test_every_rule_and_planner_is_declared_with_a_class_and_no_learned_agent_is() -> None:
    assert built_agents() == REACTIVE_AGENTS + PLANNERS
    for entry in AGENT_TABLE:
        if entry.kind == "learned":
            assert not entry.class_path and not entry.env and entry.search_space is None, entry.name
            continue
        built = agent_class(entry.name)
        assert built.__module__.startswith("agents.policies."), entry.name  # the policies layer builds them
        assert set(requested_env_kwargs(entry.name)) <= set(SETTING_NAMES), entry.name
    assert all(issubclass(planner_class(name), PlannerAgent) for name in PLANNERS)
    assert tunable_agents() == ("bee", "bee_robust", "vfh")


def test_the_declarations_give_the_env_settings_and_search_spaces_they_gave_before() -> None:
    unresolved = {"observe_unresolved": True}
    assert {name: agent_env_kwargs(name) for name in built_agents()} == {
        "straight": {},
        "bee": {},
        "bee_robust": unresolved,
        "bee_ttc": unresolved,
        "vfh": unresolved,
        "planner": {"observe_layout": True},
        "planner_camera": {"observe_layout": True},
        "planner_camera_observed": {"observe_layout": True},
        # The same planner at the resolutions agents use: a histogram's sectors and bin edges are tuples.
        "planner_camera_observed_3x15": {
            "observe_layout": True,
            "histogram_sectors": (3, 15),
            "depth_bin_edges": (0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 5.0, 8.0, 13.0),
        },
        "planner_camera_observed_1x32": {
            "observe_layout": True,
            "histogram_sectors": (1, 32),
            "depth_bin_edges": (0.0, *(0.25 * k for k in range(1, 13)), 5.0, 8.0, 13.0),
        },
        "planner_camera_filtered": {"observe_layout": True},
        "planner_camera_filtered_3x15": {
            "observe_layout": True,
            "histogram_sectors": (3, 15),
            "depth_bin_edges": (0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 5.0, 8.0, 13.0),
        },
    }
    bee = {
        "centring_gain": (0.1, 4.0, True),
        "frontal_gain": (0.5, 10.0, True),
        "frontal_threshold": (0.03, 1.0, True),
        "yaw_gain": (0.01, 2.0, True),
    }
    # Order matters: the TPE sampler draws the gains in it.
    assert list(search_space("bee").items()) == list(bee.items())
    robust = {**bee, "quantile": (0.05, 1.0, False), "smoothing": (0.1, 1.0, False)}
    assert list(search_space("bee_robust").items()) == list(robust.items())
    assert list(search_space("vfh").items()) == [
        ("safe_distance_m", (1.0, 13.0, True)),
        ("threshold", (0.01, 0.5, True)),
        ("lateral_gain", (0.2, 4.0, True)),
        ("yaw_gain", (0.1, 4.0, True)),
        ("obstacle_rows", (1, 3, False)),
    ]
    assert isinstance(search_space("vfh")["obstacle_rows"][0], int)


def test_the_straight_flight_keeps_its_defaults_whatever_gains_it_is_given() -> None:
    assert agent_parameters("straight", height_gain=9.0) == agent_parameters("straight")
    assert load_agent("bee", centring_gain=0.5).centring_gain == 0.5  # type: ignore[attr-defined]


def test_a_declared_rule_is_built_flown_with_its_env_settings_and_tunable(toy_rule: str) -> None:
    assert (
        toy_rule in built_agents() and toy_rule in tunable_agents() and toy_rule in agents_where(kind="rule")
    )
    agent = load_agent(toy_rule, sideways=0.2)
    assert isinstance(agent, ToyRule) and agent.sideways == 0.2
    assert agent_env_kwargs(toy_rule) == {"observe_unresolved": True}
    assert agent_parameters(toy_rule)["sideways"] == 0.0 and not is_privileged(toy_rule)
    assert default_params(toy_rule) == {"heading_gain": 1.5, "sideways": 0.0}
    check_agent(toy_rule)
    unregister_agent(toy_rule)
    with pytest.raises(ValueError, match=r"agent must be one of straight, .*got 'toy_rule'"):
        load_agent(toy_rule)
    register_agent(toy_rule, TOY_DECLARATION)  # for the fixture to take back


def test_a_name_declared_twice_is_refused(toy_rule: str) -> None:
    with pytest.raises(
        ValueError, match=r"^agent 'bee' is already declared; declared agents: straight, bee, "
    ):
        register_agent("bee", TOY_DECLARATION)
    with pytest.raises(
        ValueError, match=r"^agent 'toy_rule' is already declared; declared agents: .*toy_rule$"
    ):
        register_agent(toy_rule, TOY_DECLARATION)


def test_only_a_registered_agent_can_be_unregistered(toy_rule: str) -> None:
    with pytest.raises(
        ValueError,
        match=r"^only an agent declared with register_agent can be unregistered \(toy_rule\), got 'bee'$",
    ):
        unregister_agent("bee")
    assert "bee" in AGENTS


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (
            lambda: agent_class("ppo_flow"),
            r"^agent must be one of straight, bee, bee_robust, bee_ttc, vfh, planner, planner_camera, "
            r"planner_camera_observed, planner_camera_observed_3x15, planner_camera_observed_1x32, "
            r"planner_camera_filtered, planner_camera_filtered_3x15 \(built from a class\), got 'ppo_flow'$",
        ),
        (
            lambda: search_space("straight"),
            r"^agent must be one of bee, bee_robust, vfh \(tunable\), got 'straight'$",
        ),
        (
            lambda: planner_class("bee"),
            r"^a planner must be one of planner, planner_camera, planner_camera_observed, "
            r"planner_camera_observed_3x15, planner_camera_observed_1x32, planner_camera_filtered, "
            r"planner_camera_filtered_3x15, got 'bee'$",
        ),
        (lambda: check_agent("bee_ttc"), r"^--agent must be one of bee, bee_robust, vfh, got 'bee_ttc'$"),
    ],
)
def test_an_agent_of_the_wrong_kind_is_refused_with_the_allowed_ones(call, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        call()


def _toy_with(**changes: object) -> dict[str, object]:
    return {**TOY_DECLARATION, **changes}


@pytest.mark.parametrize(
    ("declaration", "call", "message"),
    [
        (
            _toy_with(search_space={"heading_gain": [0.5, 3.0, "log"], "nope": [0.0, 1.0, "linear"]}),
            agent_class,
            r"^agent 'toy_bad' search_space names nope, which ToyRule has no field of; its fields: "
            r"flight_height, height_gain, heading_gain, sideways, label$",
        ),
        (
            _toy_with(**{"class": "toy_agents:Missing"}),
            agent_class,
            r"^agent 'toy_bad' class toy_agents:Missing cannot be imported: module 'toy_agents' has no attribute "
            r"'Missing'$",
        ),
        (
            _toy_with(**{"class": "no_such_module_anywhere:Rule"}),
            agent_class,
            r"^agent 'toy_bad' class no_such_module_anywhere:Rule cannot be imported: No module named "
            r"'no_such_module_anywhere'$",
        ),
        (
            _toy_with(**{"class": "toy_agents:NotADataclass"}),
            agent_class,
            r"^agent 'toy_bad' class toy_agents:NotADataclass must be a dataclass of its gains, got <class ",
        ),
        (
            _toy_with(env={"observe_unresolvd": True}),
            requested_env_kwargs,
            r"^agent 'toy_bad' env: unknown setting 'observe_unresolvd'; known: .* \(did you mean "
            r"'observe_unresolved'\?\)$",
        ),
        (
            _toy_with(search_space={"label": [0.0, 1.0, "linear"]}),
            default_params,
            r"^agent 'toy_bad' search_space names label, whose defaults are not numbers; numeric gains: "
            r"flight_height, height_gain, heading_gain, sideways$",
        ),
        (
            {"kind": "planner", "sees": "layout", "class": "toy_agents:ToyRule"},
            planner_class,
            r"^planner 'toy_bad' class toy_agents:ToyRule must be a PlannerAgent$",
        ),
    ],
)
def test_a_declaration_its_class_does_not_bear_out_is_refused_on_use(declaration, call, message: str) -> None:
    with declared_agent("toy_bad", declaration), pytest.raises(ValueError, match=message):
        call("toy_bad")


def test_a_gain_the_class_lacks_is_refused_when_flown() -> None:
    with pytest.raises(ValueError, match=r"^agent 'bee' has no such parameter: .*'sideways'"):
        agent_parameters("bee", sideways=0.1)


def test_the_declarations_are_frozen() -> None:
    with pytest.raises(dataclasses.FrozenInstanceError):
        AGENTS["bee"].class_path = "x:Y"  # type: ignore[misc]
