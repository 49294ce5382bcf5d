"""FlowNavEnv's read-only views for studies and benchmarks: the last frame, the last depth points and the
per-stage timing of steps."""

from __future__ import annotations

import time

import numpy as np
import pytest
from helpers import SMALL

from flownav_env import FlowNavEnv
from flownav_env.rendering import CameraRenderer
from flownav_env.stage_timing import STAGES, StageTimes

ACTION = np.array([0.2, -0.1, 0.3], np.float32)


@pytest.fixture
def env():
    made = FlowNavEnv(**SMALL)
    yield made
    made.close()


def test_last_frame_and_depth_points_are_what_the_step_saw(env) -> None:
    assert env.last_frame is None and env.last_depth_points is None
    env.reset(seed=0)
    first = env.last_frame
    assert first.shape == (SMALL["camera_height"], SMALL["camera_width"], 3) and first.dtype == np.uint8
    _, _, _, _, info = env.step(ACTION)
    points = env.last_depth_points
    assert env.last_frame is not first  # a new frame, the old one left as it was
    assert points.num_points == info["points_tracked"] and points.num_valid == info["points_valid"]
    # The frame is the camera's view of the state the step left: rendering it again gives the same image.
    camera = CameraRenderer(env.physics.model, SMALL["camera_width"], SMALL["camera_height"], onboard=True)
    try:
        np.testing.assert_array_equal(env.last_frame, camera.render(env.physics.data, env.physics.camera_id))
    finally:
        camera.close()


def test_stage_times_add_up_within_the_step(env) -> None:
    env.reset(seed=0)
    times = env.time_stages()
    assert env.time_stages() is times  # one set of totals per env
    assert times.snapshot() == dict.fromkeys(STAGES, 0.0)
    before = times.snapshot()
    start = time.perf_counter()
    env.step(ACTION)
    elapsed = time.perf_counter() - start
    spent = {stage: times.snapshot()[stage] - before[stage] for stage in STAGES}
    assert all(spent[stage] > 0 for stage in ("physics", "render", "estimator"))
    assert spent["ground_truth"] > 0  # the default config asks for true depths (info["depth_error_median"])
    assert sum(spent.values()) <= elapsed
    # Timing does not change what the env computes.
    untimed = FlowNavEnv(**SMALL)
    try:
        untimed.reset(seed=0)
        untimed.step(ACTION)
        np.testing.assert_array_equal(untimed.last_frame, env.last_frame)
    finally:
        untimed.close()
    # A reset times its first frame and estimate too.
    before = times.snapshot()
    env.reset(seed=1)
    assert all(times.snapshot()[stage] > before[stage] for stage in ("render", "estimator"))


def test_stage_times_refuse_an_unknown_stage() -> None:
    with pytest.raises(ValueError, match="stage must be one of physics, render, estimator, ground_truth"):
        with StageTimes().stage("policy"):
            pass
