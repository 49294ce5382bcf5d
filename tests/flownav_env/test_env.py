"""FlowNav-v0: API conformance, determinism, episode ends, sensor extremes, bad kwargs, resource release."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import flownav_env
from flownav_env import ENV_IDS, FlowNavEnv
from flownav_env.observation import STATE_FIELDS
from flownav_env.settings import ENV_ESTIMATOR_DEFAULTS

SMALL = {"camera_width": 64, "camera_height": 48}


def make(env_id: str = "FlowNav-v0", **kwargs) -> gym.Env:
    return gym.make(env_id, **{**SMALL, **kwargs})


@pytest.mark.parametrize("env_id", sorted(ENV_IDS))
def test_registered_ids_pass_gymnasium_and_sb3_checkers(env_id: str) -> None:
    env = make(env_id)
    try:
        gym_check_env(env.unwrapped, skip_render_check=True)
        sb3_check_env(env.unwrapped, warn=False)
    finally:
        env.close()


def test_same_seed_gives_identical_observations() -> None:
    def rollout() -> list[np.ndarray]:
        env = make(attitude_jitter_deg=1.0, rotation_error=0.05, translation_error=0.05)
        obs, _ = env.reset(seed=123)
        frames = [np.concatenate([obs["depth_histogram"].ravel(), obs["state"]])]
        actions = np.random.default_rng(0).uniform(-1, 1, (8, 3))
        for action in actions:
            obs, *_ = env.step(action)
            frames.append(np.concatenate([obs["depth_histogram"].ravel(), obs["state"]]))
        env.close()
        return frames

    first, second = rollout(), rollout()
    for a, b in zip(first, second, strict=False):
        np.testing.assert_array_equal(a, b)


def test_hover_is_valid_and_keeps_position() -> None:
    env = make(forward_speed=0.0)
    env.reset(seed=2)
    for _ in range(10):
        _obs, _, terminated, _, info = env.step(np.zeros(3))
    env.close()
    assert not terminated
    assert abs(info["progress"]) < 0.05
    assert info["points_valid"] == 0  # no translation, no parallax: nothing is claimed


def test_flying_straight_into_a_capsule_terminates_with_collision() -> None:
    env = make("FlowNavSingle-v0")
    env.reset(seed=0)
    for _ in range(200):
        _, _reward, terminated, truncated, info = env.step(np.zeros(3))
        if terminated or truncated:
            break
    env.close()
    assert terminated and not truncated
    assert info["collision"] and not info["success"]
    assert info["reward_collision"] < 0
    assert 3.5 < info["progress"] < 5.0  # the capsule stands at x = 5 m with radius 0.5 m


@pytest.mark.parametrize("clearance_weight", [0.0, 2.0])
def test_clearance_shaping_costs_only_closer_than_the_safe_clearance(clearance_weight: float) -> None:
    env = make("FlowNavSingle-v0", clearance_weight=clearance_weight, safe_clearance=1.0)
    env.reset(seed=0)
    penalties = []
    for _ in range(200):
        _, reward, terminated, truncated, info = env.step(np.zeros(3))
        terms = [value for key, value in info.items() if key.startswith("reward_")]
        assert reward == pytest.approx(sum(terms)) and len(terms) == 5
        expected = clearance_weight * max(0.0, 1.0 - info["clearance"] / 1.0)
        assert info["reward_clearance"] == pytest.approx(-expected)
        penalties.append(-info["reward_clearance"])
        if terminated or truncated:
            break
    env.close()
    assert penalties[0] == 0.0  # the capsule is 5 m ahead at the start
    assert (max(penalties) > 1.0) == (clearance_weight > 0)  # straight into it: within half a metre


def test_safe_clearance_out_of_range_is_rejected() -> None:
    with pytest.raises(ValueError, match=r"safe_clearance must be in \(0.0, 5.0\], got 0.0"):
        FlowNavEnv(safe_clearance=0.0)


def test_reaching_the_goal_ends_with_success() -> None:
    env = make("FlowNavSingle-v0", forward_speed=2.0)
    env.reset(seed=0)
    # Sidestep the capsule by flying right, then carry on to the goal line.
    for step in range(200):
        action = np.array([1.0 if step < 25 else 0.0, 0.0, 0.0])
        _, _reward, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
    env.close()
    assert terminated and info["success"] and not info["collision"]
    assert info["reward_success"] > 0


def test_leaving_the_bounds_terminates() -> None:
    env = make(lateral_bound=1.0)
    env.reset(seed=0)
    for _ in range(100):
        _, _, terminated, _, info = env.step(np.array([-1.0, 0.0, 0.0]))
        if terminated:
            break
    env.close()
    assert terminated and info["out_of_bounds"] and not info["collision"]


def test_body_tilts_when_accelerating_sideways() -> None:
    env = make(forward_speed=0.0)
    env.reset(seed=0)
    obs, *_ = env.step(np.array([1.0, 0.0, 0.0]))
    env.close()
    roll = obs["state"][3]
    assert abs(np.degrees(roll)) > 2.0


def test_rgb_array_render_shows_camera_and_chase_views() -> None:
    env = make(render_mode="rgb_array")
    env.reset(seed=0)
    env.step(np.zeros(3))
    frame = env.render()
    env.close()
    assert frame.shape == (240, 640, 3) and frame.dtype == np.uint8
    assert frame[:, :320].std() > 5 and frame[:, 320:].std() > 5


def test_info_carries_truth_and_estimator_statistics() -> None:
    env = make(rotation_error=0.1, translation_error=0.1)
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.zeros(3))
    env.close()
    for key in (
        "collision",
        "success",
        "progress",
        "min_clearance",
        "points_tracked",
        "points_valid",
        "true_rotation",
        "true_translation",
    ):
        assert key in info
    np.testing.assert_allclose(info["true_rotation"] @ info["true_rotation"].T, np.eye(3), atol=1e-9)
    assert 0.05 < np.linalg.norm(info["true_translation"]) < 0.15  # ≈ 0.1 m per frame by default


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"forward_speed": -1.0}, r"forward_speed must be in \[0.0, 5.0\], got -1.0"),
        ({"layout": "maze"}, r"layout must be one of 'field', 'corridor', 'single', 'three', got 'maze'"),
        ({"camera_width": 0}, r"camera_width must be an integer in \[16, 1280\], got 0"),
        ({"camera_height": 10_000}, r"camera_height must be an integer in \[16, 1280\], got 10000"),
        ({"rotation_error": 1.5}, r"rotation_error must be in \[0.0, 1.0\], got 1.5"),
        ({"translation_error": -0.1}, r"translation_error must be in \[0.0, 1.0\], got -0.1"),
        ({"attitude_jitter_deg": float("nan")}, r"attitude_jitter_deg must be in \[0.0, 10.0\], got nan"),
        ({"brightness": -0.5}, r"brightness must be in \[0.0, 4.0\], got -0.5"),
        ({"observe_unresolved": "yes"}, r"observe_unresolved must be True or False, got 'yes'"),
        ({"obs_source": "lidar"}, r"obs_source must be one of 'flow', 'oracle', 'oracle_valid', got 'lidar'"),
        ({"frame_rate": 0}, r"frame_rate must be in \[1.0, 50.0\], got 0"),
        ({"histogram_sectors": (0, 3)}, r"histogram_sectors\[0\] must be an integer in \[1, 32\], got 0"),
        ({"histogram_sectors": 3}, r"histogram_sectors must be \(rows, cols\), got 3"),
        ({"depth_bin_edges": (1.0, 0.5)}, r"depth_bin_edges must be >= 2 increasing finite depths"),
        ({"obstacle_density": 2.0}, r"obstacle_density must be in \[0.0, 1.0\], got 2.0"),
        ({"obstacle_radius": 0.0}, r"obstacle_radius must be in \(0.0, 2.0\], got 0.0"),
        ({"max_height": 0.5}, r"max_height must be in \(1.0, 20.0\], got 0.5"),
        ({"physics_timestep": 0.01}, r"physics_timestep must be in \[0.0005, 0.005\], got 0.01"),
        ({"render_mode": "human"}, r"render_mode must be one of 'rgb_array', got 'human'"),
        ({"texture_seed": "a"}, r"texture_seed must be an integer, got 'a'"),
        ({"success_bonus": -1.0}, r"success_bonus must be in \[0.0, inf\), got -1.0"),
        (
            {"estimator_kwargs": 5},
            r"estimator_kwargs must be a mapping of FlowDepthEstimator arguments, got 5",
        ),
        (
            {"estimator_kwargs": {"fast_thresh": 3}},
            r"unknown keys \['fast_thresh'\]; allowed: method, fast_t",
        ),
        ({"estimator_kwargs": {"fast_threshold": 0}}, r"fast_threshold must be an integer with 1 <= "),
    ],
)
def test_bad_kwargs_raise_value_error_naming_kwarg_value_and_range(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        FlowNavEnv(**{**SMALL, **kwargs})


def test_env_estimator_defaults_apply_under_the_callers_estimator_kwargs() -> None:
    assert FlowNavEnv(**SMALL).estimator.fast_threshold == ENV_ESTIMATOR_DEFAULTS["fast_threshold"]
    tuned = FlowNavEnv(**SMALL, estimator_kwargs={"fast_threshold": 33, "max_points": 50})
    assert (tuned.estimator.fast_threshold, tuned.estimator.max_points) == (33, 50)


def test_non_finite_action_is_rejected() -> None:
    env = FlowNavEnv(**SMALL)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action must be finite"):
        env.step(np.array([np.nan, 0.0, 0.0]))
    env.close()


def test_env_id_table_matches_registry() -> None:
    for env_id, (kwargs, steps) in flownav_env.ENV_IDS.items():
        spec = gym.spec(env_id)
        assert spec.max_episode_steps == steps
        assert spec.kwargs["layout"] == kwargs["layout"]


def _table_after(doc: str, heading: str) -> list[list[str]]:
    """Rows (cells) of the first Markdown table after ``heading`` in a docstring, header and rule dropped."""
    lines = doc[doc.index(heading) :].splitlines()
    start = next(i for i, line in enumerate(lines) if line.strip().startswith("|"))
    rows = []
    for line in lines[start:]:
        if not line.strip().startswith("|"):
            break
        rows.append([cell.strip() for cell in line.strip().strip("|").split("|")])
    return rows[2:]


def test_docstring_tables_match_the_spaces_and_the_constructor() -> None:
    import re
    from dataclasses import fields

    from flownav_env.settings import EnvSettings

    doc = FlowNavEnv.__doc__
    env = FlowNavEnv(**SMALL)
    env.close()
    assert len(_table_after(doc, "## Action Space")) == env.action_space.shape[0]
    state_rows = _table_after(doc, "``state`` (clipped")
    assert len(state_rows) == env.observation_space["state"].shape[0] == len(STATE_FIELDS)
    documented = set()
    for row in _table_after(doc, "## Arguments"):
        documented.update(re.findall(r"``(\w+)``", row[0]))
    # The constructor's keywords: a whole EnvSettings, any of its fields, and the render mode.
    assert documented == {"settings", "render_mode", *(item.name for item in fields(EnvSettings))}


def test_depth_error_info_can_be_skipped_where_only_flow_is_observed() -> None:
    def last_info(**kwargs) -> dict:
        env = FlowNavEnv(**SMALL, **kwargs)
        env.reset(seed=0)
        for _ in range(5):
            _, _, _, _, info = env.step(np.zeros(3))
        env.close()
        return info

    info = last_info()
    assert "depth_error_median" in info and 0.0 <= info["depth_outlier_share"] <= 1.0
    skipped = last_info(depth_error_info=False)
    assert "depth_error_median" not in skipped and "depth_outlier_share" not in skipped
    assert skipped["points_valid"] == info["points_valid"]
    # Oracle observations need the true depths whatever the flag says.
    assert "depth_error_median" in last_info(depth_error_info=False, obs_source="oracle")
    with pytest.raises(ValueError, match="depth_error_info must be True or False"):
        FlowNavEnv(**SMALL, depth_error_info=1)


def test_estimator_info_counts_depths_off_by_more_than_half_as_outliers() -> None:
    from types import SimpleNamespace

    from estimator.accuracy import OUTLIER_RELATIVE_ERROR
    from flownav_env.observation import estimator_info

    true_depth = np.array([2.0, 2.0, 2.0, 2.0, 2.0, np.nan])
    depth = np.array(
        [2.1, 3.2, 0.9, 5.0, 2.0, 4.0]
    )  # relative errors 0.05, 0.6, 0.55, 1.5, (invalid), (no truth)
    valid = np.array([True, True, True, True, False, True])
    info = estimator_info(SimpleNamespace(depth=depth, valid=valid), true_depth)
    assert OUTLIER_RELATIVE_ERROR == 0.5
    assert info["points_valid"] == 5 and info["depth_outlier_share"] == pytest.approx(3 / 4)
    assert "depth_outlier_share" not in estimator_info(
        SimpleNamespace(depth=depth, valid=valid), np.array([])
    )
