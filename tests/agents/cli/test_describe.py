"""``flownav describe``: the agent contract of a tier, read from a real env of it."""

from __future__ import annotations

import gymnasium as gym
import pytest

import flownav_env  # noqa: F401
from agents.cli import main
from agents.cli.describe import describe_tier
from agents.policies.external import PREDICT_SIGNATURE
from flownav_env.tiers import TIER_NAMES, tier


def table_rows(text: str, header_start: str) -> list[list[str]]:
    """The body rows of the markdown table in ``text`` whose header starts with ``header_start``."""
    lines = text.splitlines()
    start = next(index for index, line in enumerate(lines) if line.startswith(header_start))
    rows = []
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        rows.append([cell.strip() for cell in line.strip("|").split("|")])
    return rows


@pytest.mark.parametrize("tier_name", ["clean", "hard"])
def test_describe_gives_every_key_with_the_env_s_shape_and_the_action_with_units(tier_name: str) -> None:
    text = "\n".join(describe_tier(tier_name))
    env = gym.make(tier(tier_name).env_id, observe_approach=True)
    try:
        approach, histogram = env.observation_space["approach"], env.observation_space["depth_histogram"]
        action_space = env.action_space
    finally:
        env.close()
    keys = {row[0]: row for row in table_rows(text, "| key |")}
    assert set(keys) == {"depth_histogram", "state", "unresolved", "point_counts", "nearness", "approach"}
    assert keys["depth_histogram"][1:4] == [str(histogram.shape), "float32", "[0, 1]"]
    assert keys["approach"][1] == str(approach.shape) and "observe_approach=True" in keys["approach"][4]
    assert "observe_" not in keys["depth_histogram"][4]  # given to every agent
    assert len(table_rows(text, "| index | observation |")) == env.observation_space["state"].shape[0]
    actions = table_rows(text, "| index | action |")
    assert len(actions) == action_space.shape[0]
    assert actions[0][1] == "lateral velocity (right)" and actions[0][5] == "m/s"
    assert actions[2][4].endswith("= ±45") and actions[2][5] == "deg/s"
    assert PREDICT_SIGNATURE in text and f"Tier {tier_name} ({tier(tier_name).env_id})" in text


def test_describe_resolves_the_tier_s_own_forward_speed() -> None:
    assert "forward_speed is 2 m/s" in "\n".join(describe_tier("hard"))
    assert "forward_speed is 1 m/s" in "\n".join(describe_tier("clean"))


def test_describe_defaults_to_the_first_tier(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["describe"]) == 0
    assert capsys.readouterr().out.startswith(f"Tier {TIER_NAMES[0]} ")


def test_describe_of_an_unknown_tier_is_one_line_and_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["describe", "--tiers", "hrad"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (
        "flownav describe: error: tier must be one of clean, hard, noisy, hard_noisy, got 'hrad'; did you mean 'hard'?"
    )


def test_score_help_and_flownav_help_point_to_describe_and_the_leading_table(
    capsys: pytest.CaptureFixture[str],
) -> None:
    with pytest.raises(SystemExit):
        main(["score", "--help"])
    assert "flownav describe [--tiers TIER]" in " ".join(capsys.readouterr().out.split())
    with pytest.raises(SystemExit):
        main(["--help"])
    top = " ".join(capsys.readouterr().out.split())
    assert "The leading table is results/suite.md (flownav suite)" in top and "flownav describe" in top


def test_describe_gives_the_bin_edges_values_the_signs_and_every_setting_of_the_tier() -> None:
    from flownav_env.settings import EnvSettings

    text = "\n".join(describe_tier("hard"))
    edges = EnvSettings().depth_bin_edges
    assert f"depth_bin_edges {list(edges)}: [{edges[0]:g}, {edges[1]:g})," in text
    assert f"the last one also counting what lies beyond {edges[-1]:g} m" in text
    signs = {row[0]: row[1] for row in table_rows(text, "| quantity | positive means |")}
    assert signs["state[1] lateral velocity"].startswith("to the left")
    assert signs["state[6] heading error"].startswith("turned to the left")
    assert signs["action 0, lateral velocity"].startswith("to the right")
    assert signs["action 2, yaw rate"].startswith("to the right (clockwise)")
    settings = {row[0]: row[1] for row in table_rows(text, "| setting | value |")}
    assert settings["forward_speed *"] == "2.0" and settings["obstacle_density *"] == "0.18"
    assert settings["observe_approach"] == "False"  # the env's default, not describe's own every-key env
    assert len(settings) == len(EnvSettings.__dataclass_fields__)


def test_the_signs_describe_states_are_the_env_s() -> None:
    import numpy as np

    env = gym.make("FlowNavSingle-v0", camera_width=64, camera_height=48)
    try:
        for action, entry in (([1.0, 0.0, 0.0], 1), ([0.0, 0.0, 1.0], 6)):
            observation, _ = env.reset(seed=0)
            for _ in range(5):
                observation, *_ = env.step(np.array(action, np.float32))
            # A positive action (to the right) makes the left-positive state entry negative.
            assert observation["state"][entry] < 0
    finally:
        env.close()
