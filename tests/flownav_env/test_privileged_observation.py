"""observe_layout: the privileged keys appear only when asked for, with their documented shapes, and hold the
episode's true capsules and the drone's true state."""

from __future__ import annotations

import re

import gymnasium as gym
import numpy as np
import pytest

import flownav_env  # noqa: F401  (registers the env ids)
from flownav_env.privileged import (
    CAMERA_FIELDS,
    COURSE_INFO_FIELDS,
    MAX_CAPSULES,
    PRIVILEGED_KEYS,
    TRUE_STATE_FIELDS,
    capsule_layout,
)
from flownav_env.tiers import TIERS

SMALL = {"camera_width": 64, "camera_height": 48, "depth_error_info": False}


def test_the_privileged_keys_appear_only_with_observe_layout() -> None:
    env = gym.make("FlowNav-v0", **SMALL)
    try:
        observation, _ = env.reset(seed=950_000)
        assert not set(PRIVILEGED_KEYS) & set(observation)
        assert not set(PRIVILEGED_KEYS) & set(env.observation_space.spaces)
    finally:
        env.close()


def test_the_keys_hold_the_scenes_capsules_and_the_true_state() -> None:
    env = gym.make(TIERS["hard"].env_id, **TIERS["hard"].settings, observe_layout=True, **SMALL)
    try:
        observation, _ = env.reset(seed=950_000)
        observation, *_ = env.step(np.array([0.5, 0.0, 0.0]))
        assert env.observation_space.contains(observation)
        physics = env.unwrapped.physics
        layout, mask, state, course = (observation[key] for key in PRIVILEGED_KEYS[:4])
        assert layout.shape == (MAX_CAPSULES, 3) and mask.shape == (MAX_CAPSULES,)
        assert state.shape == (len(TRUE_STATE_FIELDS),) and course.shape == (len(COURSE_INFO_FIELDS),)
        count = len(physics.obstacle_positions)
        assert 0 < count and mask.sum() == count and not mask[count:].any()
        np.testing.assert_allclose(layout[:count, :2], physics.obstacle_positions, atol=1e-5)
        assert (layout[:count, 2] == 0.5).all() and not layout[count:].any()
        np.testing.assert_allclose(state[:3], physics.position(), atol=1e-5)
        np.testing.assert_allclose(state[3:6], physics.velocity_world(), atol=1e-5)
        assert state[TRUE_STATE_FIELDS.index("yaw")] == pytest.approx(physics.yaw(), abs=1e-6)
        named = dict(zip(COURSE_INFO_FIELDS, course.tolist(), strict=True))
        assert named["goal_x"] == 20.0 and named["forward_speed"] == 2.0 and named["frame_rate"] == 10.0
        assert named["drone_radius"] == pytest.approx(physics.quad.collision_radius)
    finally:
        env.close()


def test_the_camera_key_holds_its_true_pose_and_view_and_the_bin_edges_are_the_settings() -> None:
    edges = (0.0, 0.5, 1.0, 2.0, 4.0)
    env = gym.make("FlowNav-v0", observe_layout=True, depth_bin_edges=edges, **SMALL)
    try:
        env.reset(seed=950_000)
        observation, *_ = env.step(np.array([0.5, 0.0, 0.2]))
        assert env.observation_space.contains(observation)
        physics = env.unwrapped.physics
        camera = dict(zip(CAMERA_FIELDS, observation["camera"].tolist(), strict=True))
        rotation, position = physics.camera_pose()
        np.testing.assert_allclose([camera["x"], camera["y"], camera["z"]], position, atol=1e-5)
        np.testing.assert_allclose(observation["camera"][3:12].reshape(3, 3), rotation, atol=1e-6)
        intrinsics = env.unwrapped.settings.intrinsics()
        assert camera["fx"] == pytest.approx(intrinsics.fx, rel=1e-6) and camera["cx"] == intrinsics.cx
        assert camera["width"] == SMALL["camera_width"]
        np.testing.assert_array_equal(observation["depth_bin_edges"], np.array(edges, np.float32))
    finally:
        env.close()


def test_the_env_checkers_pass_with_observe_layout() -> None:
    from gymnasium.utils.env_checker import check_env as gymnasium_check
    from stable_baselines3.common.env_checker import check_env as sb3_check

    env = gym.make(TIERS["hard_noisy"].env_id, observe_layout=True, **SMALL)
    try:
        gymnasium_check(env.unwrapped, skip_render_check=True)
        sb3_check(env.unwrapped, warn=True)
    finally:
        env.close()


def test_a_layout_beyond_the_pool_is_one_line() -> None:
    with pytest.raises(
        ValueError, match=re.escape(f"at most {MAX_CAPSULES} capsules, got {MAX_CAPSULES + 1}")
    ):
        capsule_layout(np.zeros((MAX_CAPSULES + 1, 2)), 0.5)
