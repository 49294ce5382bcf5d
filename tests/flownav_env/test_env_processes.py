"""FlowNavEnv across processes and over its lifetime: subprocess vector envs, fork, close, memory."""

from __future__ import annotations

import gc
import resource

import gymnasium as gym
import numpy as np
import pytest

from flownav_env import FlowNavEnv

SMALL = {"camera_width": 64, "camera_height": 48}


def make(env_id: str = "FlowNav-v0", **kwargs) -> gym.Env:
    return gym.make(env_id, **{**SMALL, **kwargs})


def test_make_close_cycles_do_not_grow_memory() -> None:
    def cycle() -> None:
        env = make(render_mode="rgb_array")
        env.reset(seed=0)
        env.step(np.zeros(3))
        env.render()
        env.close()

    for _ in range(2):  # warm up allocator pools and GL driver caches
        cycle()
    gc.collect()
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    # Eight cycles (each a model build and a GL context, ~1 s) catch a leak of 5 MiB a cycle: a model, a
    # renderer or a frame buffer kept alive.
    for _ in range(8):
        cycle()
    gc.collect()
    grown_mib = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) / 1024
    assert grown_mib < 40, f"peak RSS grew {grown_mib:.1f} MiB over 8 make/close cycles"


@pytest.mark.parametrize("vector", ["sb3_subproc", "gym_async"])
def test_env_steps_inside_subprocess_vector_envs(vector: str) -> None:
    if vector == "sb3_subproc":
        from stable_baselines3.common.env_util import make_vec_env
        from stable_baselines3.common.vec_env import SubprocVecEnv

        # "module:id" makes each worker import flownav_env (and so register the ids) before gym.make.
        envs = make_vec_env(
            "flownav_env:FlowNav-v0", n_envs=2, seed=0, vec_env_cls=SubprocVecEnv, env_kwargs=SMALL
        )
        envs.reset()
        obs, rewards, _dones, _infos = envs.step(np.zeros((2, 3), np.float32))
        envs.close()
        assert obs["depth_histogram"].shape[0] == 2 and np.all(np.isfinite(rewards))
    else:
        # A forked child inherits the parent's EGL state, which hangs once the parent has rendered: fork server.
        envs = gym.vector.AsyncVectorEnv(
            [lambda: make(render_mode="rgb_array") for _ in range(2)], context="forkserver"
        )
        envs.reset(seed=0)
        obs, rewards, *_ = envs.step(np.zeros((2, 3), np.float32))
        frames = envs.call("render")
        envs.close()
        assert obs["state"].shape == (2, 7) and frames[0].shape == (240, 640, 3)


def test_a_closed_env_refuses_to_step_or_reset() -> None:
    env = FlowNavEnv(**SMALL)
    env.reset(seed=0)
    env.close()
    with pytest.raises(RuntimeError, match=r"step\(\) called on a closed FlowNavEnv"):
        env.step(np.zeros(3))
    with pytest.raises(RuntimeError, match=r"reset\(\) called on a closed FlowNavEnv"):
        env.reset(seed=0)


def _make_an_env_in_a_forked_child(queue) -> None:
    try:
        FlowNavEnv(**SMALL).reset(seed=0)
        queue.put("rendered")
    except Exception as error:  # the child reports whatever it raised
        queue.put(f"{type(error).__name__}: {error}")


@pytest.mark.skipif(__import__("os").environ.get("MUJOCO_GL") != "egl", reason="the EGL fork hang")
def test_a_child_forked_after_rendering_raises_instead_of_hanging() -> None:
    import multiprocessing

    parent = FlowNavEnv(**SMALL)
    parent.reset(seed=0)  # this process has rendered with EGL
    context = multiprocessing.get_context("fork")
    queue = context.Queue()
    child = context.Process(target=_make_an_env_in_a_forked_child, args=(queue,))
    child.start()
    child.join(timeout=60)
    hung = child.is_alive()
    if hung:
        child.kill()
    parent.close()
    assert not hung, "the forked child hung instead of raising"
    message = queue.get(timeout=5)
    assert message.startswith("ForkedGLContextError") and "'spawn'" in message and "'forkserver'" in message
