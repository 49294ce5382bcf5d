"""FlowNav-v0's observation: what each histogram, share, nearness and approach key holds, and its finiteness at
the sensor's extremes."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import flownav_env  # noqa: F401  (registers the ids)

SMALL = {"camera_width": 64, "camera_height": 48}


def make(env_id: str = "FlowNav-v0", **kwargs) -> gym.Env:
    return gym.make(env_id, **{**SMALL, **kwargs})


def test_unresolved_share_complements_the_histogram() -> None:
    env = make(observe_unresolved=True)
    obs, _ = env.reset(seed=2)
    assert not obs["unresolved"].any()  # nothing tracked before the first pair
    seen_partial = False
    for _ in range(6):
        obs, *_, info = env.step(np.zeros(3))
        ranged = obs["depth_histogram"].sum(-1) > 0
        # a sector whose tracked points are all unresolved has no ranged point, and vice versa
        assert not np.any((obs["unresolved"] == 1.0) & ranged)
        assert np.all(ranged[(obs["unresolved"] > 0) & (obs["unresolved"] < 1)])
        seen_partial |= bool(np.any((obs["unresolved"] > 0) & (obs["unresolved"] < 1)))
    assert seen_partial and info["points_tracked"] > info["points_valid"]
    env.close()


def test_point_counts_rise_with_the_points_each_histogram_counts() -> None:
    env = make(observe_counts=True)
    obs, _ = env.reset(seed=2)
    assert env.observation_space.contains(obs) and not obs["point_counts"].any()
    for _ in range(4):
        obs, *_, info = env.step(np.zeros(3))
    ranged = obs["depth_histogram"].sum(-1) > 0
    assert np.array_equal(obs["point_counts"] > 0, ranged)  # a count where, and only where, a histogram is
    assert obs["point_counts"].max() < 1.0 and info["points_valid"] > 0
    env.close()


def test_nearness_is_high_only_where_a_sector_holds_near_depths() -> None:
    env = make(observe_nearness=True)
    obs, _ = env.reset(seed=2)
    assert env.observation_space.contains(obs) and not obs["nearness"].any()
    for _ in range(4):
        obs, *_, info = env.step(np.zeros(3))
    ranged = obs["depth_histogram"].sum(-1) > 0
    assert env.observation_space.contains(obs) and info["points_valid"] > 0
    assert np.array_equal(obs["nearness"] > 0, ranged)  # a nearness where, and only where, a histogram is
    points = env.unwrapped._depth_points
    # No sector is nearer than its nearest valid depth.
    assert obs["nearness"].max() <= min(1.0, 0.5 / points.depth[points.valid].min()) + 1e-6
    env.close()


def test_approach_is_nearness_times_forward_speed_per_metre_per_second() -> None:
    env = make(observe_nearness=True, observe_approach=True, forward_speed=1.5)
    obs, _ = env.reset(seed=2)
    assert env.observation_space.contains(obs) and not obs["approach"].any()
    for _ in range(6):
        obs, *_ = env.step(np.zeros(3))
    speed = max(float(obs["state"][0]), 0.0)
    assert env.observation_space.contains(obs) and speed > 0.5 and obs["approach"].any()
    open_ended = obs["nearness"] < 1.0  # nearness is clipped at 1 within half a metre
    expected = np.minimum(1.0, obs["nearness"] * speed)
    assert np.allclose(obs["approach"][open_ended], expected[open_ended], atol=1e-5)
    assert np.array_equal(obs["approach"] > 0, obs["nearness"] > 0)
    env.close()


def test_oracle_valid_measures_the_estimators_valid_points_exactly() -> None:
    flow_env, truth_env = make(), make(obs_source="oracle_valid")
    flow_obs, _ = flow_env.reset(seed=3)
    truth_obs, _ = truth_env.reset(seed=3)
    differs = False
    for _ in range(8):  # the same seed and actions fly the same frames, so the same points are valid
        flow_obs, *_ = flow_env.step(np.zeros(3))
        truth_obs, *_, info = truth_env.step(np.zeros(3))
        flow_occupied = flow_obs["depth_histogram"].sum(-1) > 0
        truth_occupied = truth_obs["depth_histogram"].sum(-1) > 0
        assert not np.any(truth_occupied & ~flow_occupied)  # only sectors holding valid points
        differs |= not np.allclose(flow_obs["depth_histogram"], truth_obs["depth_histogram"])
    assert differs and info["points_valid"] > 0  # ... with their true depths, not the estimates
    flow_env.close()
    truth_env.close()


@pytest.mark.parametrize(
    "kwargs",
    [
        {"forward_speed": 0.0},  # hover: no translation, no depth
        {"forward_speed": 3.0},
        {"attitude_jitter_deg": 2.5},
        {"brightness": 0.0},
        {"brightness": 4.0},
        {"rotation_error": 1.0, "translation_error": 1.0},
        {"obs_source": "oracle"},
        {"obs_source": "oracle_valid"},
        {"observe_unresolved": True},
        {"observe_unresolved": True, "obs_source": "oracle", "forward_speed": 0.0},
    ],
    ids=lambda kwargs: ",".join(f"{k}={v}" for k, v in kwargs.items()),
)
def test_observations_finite_and_inside_space_at_sensor_extremes(kwargs: dict) -> None:
    env = make(**kwargs)
    obs, _ = env.reset(seed=1)
    assert env.observation_space.contains(obs)
    for _ in range(6):
        obs, reward, terminated, _truncated, _info = env.step(env.action_space.sample())
        assert env.observation_space.contains(obs)
        assert all(np.all(np.isfinite(value)) for value in obs.values())
        assert np.isfinite(reward)
        if terminated:
            break
    env.close()


def test_flow_observation_sees_the_obstacle_ahead() -> None:
    env = make("FlowNavSingle-v0", camera_width=160, camera_height=120)
    env.reset(seed=0)
    valid_counts = []
    for _ in range(10):
        obs, _, _, _, info = env.step(np.zeros(3))
        valid_counts.append(info["points_valid"])
    env.close()
    assert np.median(valid_counts) >= 20
    assert obs["depth_histogram"].sum() > 0
