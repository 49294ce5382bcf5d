"""``near_smoothing``: ``nearness`` and ``approach`` averaged over an episode's frames, reset with the episode,
and refused outside (0, 1] with a message naming the value and the range."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import flownav_env  # noqa: F401  (registers the ids)
from flownav_env import FlowNavEnv
from flownav_env.observation import smoothed_near

SMALL = {"camera_width": 64, "camera_height": 48}


def test_smoothed_near_averages_only_the_near_keys() -> None:
    histogram = np.ones((3, 5, 4), np.float32)
    previous = {"approach": np.full((3, 5), 0.8, np.float32), "depth_histogram": np.zeros((3, 5, 4))}
    current = {"approach": np.full((3, 5), 0.2, np.float32), "depth_histogram": histogram}
    smoothed = smoothed_near(dict(current), previous, 0.25)
    assert np.allclose(smoothed["approach"], 0.25 * 0.2 + 0.75 * 0.8)
    assert smoothed["approach"].dtype == np.float32
    assert smoothed["depth_histogram"] is histogram
    assert smoothed_near(dict(current), None, 0.25)["approach"] is current["approach"]
    assert smoothed_near(dict(current), previous, 1.0)["approach"] is current["approach"]


def test_the_env_averages_approach_over_frames_and_forgets_at_reset() -> None:
    kwargs = {**SMALL, "observe_nearness": True, "observe_approach": True, "forward_speed": 1.5}
    raw_env = gym.make("FlowNav-v0", **kwargs)
    smooth_env = gym.make("FlowNav-v0", **kwargs, near_smoothing=0.5)
    for episode in range(2):  # the second episode checks that the average starts afresh
        raw, _ = raw_env.reset(seed=2 + episode)
        smooth, _ = smooth_env.reset(seed=2 + episode)
        average = {key: raw[key] for key in ("nearness", "approach")}
        assert all(np.array_equal(smooth[key], average[key]) for key in average)
        for _ in range(12):
            raw, *_ = raw_env.step(np.zeros(3))
            smooth, *_ = smooth_env.step(np.zeros(3))
            assert np.array_equal(smooth["depth_histogram"], raw["depth_histogram"])
            for key in average:
                average[key] = 0.5 * raw[key] + 0.5 * average[key]
                assert np.allclose(smooth[key], average[key], atol=1e-6)
            assert smooth_env.observation_space.contains(smooth)
        assert raw["approach"].any()  # the capsules ahead were seen, so the average was exercised
    raw_env.close()
    smooth_env.close()


@pytest.mark.parametrize("value", [0.0, -0.5, 1.5, float("nan")])
def test_near_smoothing_outside_its_range_is_refused(value: float) -> None:
    with pytest.raises(ValueError, match=rf"near_smoothing must be in \(0.0, 1.0\], got {value}"):
        FlowNavEnv(**SMALL, near_smoothing=value)
