"""The training and evaluation environments of a run: built from its config, in worker processes that a
Ctrl-C does not kill, and closed without raising.

Ctrl-C sends SIGINT to the whole process group. Workers that die of it break their pipes, and closing the
vector env then raises (``EOFError``, ``ConnectionResetError``) before the run's outputs are written. The
workers ignore SIGINT; only the main process handles it, ends learning and saves.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import gymnasium as gym
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecEnv, VecEnvWrapper, VecFrameStack

from agents.common.interrupts import ignore_stop_signals
from agents.common.seeds import checkpoint_selection_seed, training_env_seed
from agents.training.student_view import StudentView
from agents.training.train_config import TrainConfig
from agents.training.wrappers import SensorRandomization
from flownav_env.limits import episode_step_limit  # importing flownav_env registers its ids, in workers too


def make_env_factory(
    config: TrainConfig, rank: int, teacher_settings: Mapping[str, Any] | None = None
) -> Callable[[], gym.Env]:
    """A picklable-by-closure factory for SubprocVecEnv workers (``rank`` is kept for callers that number
    their workers; the env's seed comes from the vector env). ``teacher_settings`` go on top of the config's
    ``env``: what a privileged teacher reads (:mod:`agents.training.student_view`).

    The closure holds plain values, not the config object: a worker unpickles it with the code on disk when
    it starts, which in a long multi-seed run may be newer than the main process's (a config class that
    gained a field would otherwise break every later seed).
    """
    env_id, env_kwargs = config.env_id, {"depth_error_info": False, **config.env, **(teacher_settings or {})}
    ranges = {name: list(bounds) for name, bounds in config.randomize.ranges().items() if bounds}
    # Slow episodes need the time to reach the goal: the limit of the slowest speed drawn.
    slowest = {"forward_speed": min(ranges["forward_speed"])} if "forward_speed" in ranges else {}
    limit = episode_step_limit(env_id, {**config.env, **slowest}) if slowest else None

    def factory() -> gym.Env:
        # Training reads rewards, not the depth-error diagnostics: skip their per-step ray cast unless the
        # config asks (oracle observations get true depths regardless).
        env = gym.make(env_id, max_episode_steps=limit, **env_kwargs)
        if ranges:
            env = SensorRandomization(env, ranges)
        return Monitor(env)

    return factory


class IgnoringInterrupts:
    """Wraps an env factory so that the worker process it runs in ignores SIGINT (Ctrl-C) and SIGTERM from then
    on.

    Only for factories called in a worker process: called in the main process it would disable Ctrl-C there.
    """

    def __init__(self, factory: Callable[[], gym.Env]) -> None:
        self.factory = factory

    def __call__(self) -> gym.Env:
        ignore_stop_signals()
        return self.factory()


EVAL_WORKERS = 2


def build_envs(
    config: TrainConfig, *, in_process: bool = False, teacher_settings: Mapping[str, Any] | None = None
) -> tuple[VecEnv, VecEnv]:
    """The training vector env (``n_envs`` envs, seeded from ``config.seed``) and the evaluation vector env of
    the same class (seeded from the validation seeds): SB3's EvalCallback warns when the two classes differ.

    By default the envs run in forkserver subprocesses (a forked EGL context hangs) that ignore Ctrl-C, with
    ``EVAL_WORKERS`` evaluation envs; with one env, both run in this process (one evaluation env).
    ``in_process=True`` steps the same envs, with the same seeds, in this process (``DummyVecEnv``): for
    several training seeds side by side, one process per core, where a lock-stepped worker per env loses
    cores to waiting. Both give the same rollouts.

    ``teacher_settings`` (a privileged teacher's ``observe_layout``) are given to the training envs only. A run
    with a teacher has both vector envs wrapped in :class:`~agents.training.student_view.StudentView`, so the
    policy built on them never sees the teacher's keys, and the teacher reads the current frame there when
    ``frame_stack`` stacks the student's observations above it.
    """
    factories = [make_env_factory(config, i, teacher_settings) for i in range(config.n_envs)]
    eval_count = EVAL_WORKERS if config.n_envs > 1 else 1
    eval_factories = [make_env_factory(config, i) for i in range(eval_count)]
    envs: VecEnv
    eval_env: VecEnv
    if config.n_envs > 1 and not in_process:
        envs = SubprocVecEnv([IgnoringInterrupts(f) for f in factories], start_method="forkserver")
        try:
            # Two evaluation workers halve the time the training workers sit idle during an evaluation.
            eval_env = SubprocVecEnv(
                [IgnoringInterrupts(f) for f in eval_factories], start_method="forkserver"
            )
        except BaseException:
            close_quietly(
                envs
            )  # its workers ignore stop signals: left open, they would keep the process alive
            raise
    else:
        envs, eval_env = DummyVecEnv(factories), DummyVecEnv(eval_factories)
    envs.seed(training_env_seed(config.seed))
    eval_env.seed(checkpoint_selection_seed(config.seed))
    if teacher_settings or config.imitation.teacher:
        envs, eval_env = StudentView(envs), StudentView(eval_env)
    if config.frame_stack > 1:
        envs, eval_env = VecFrameStack(envs, config.frame_stack), VecFrameStack(eval_env, config.frame_stack)
    return envs, eval_env


def close_quietly(envs: VecEnv) -> None:
    """Close a vector env whose workers may already be gone (killed, or interrupted by an older SB3): a
    broken pipe is reported in one line and the remaining workers are terminated, instead of raising and
    losing the run's outputs.

    A stop signal that lands while the workers step leaves SB3's ``waiting`` flag set with some of their
    replies already read; its ``close`` would then wait for replies that never come. Those replies do not
    matter once the env closes, so the flag is cleared first and each worker just gets its close message.
    """
    inner = envs
    while isinstance(inner, VecEnvWrapper):  # VecFrameStack and other wrappers around the workers
        inner = inner.venv
    workers = inner if isinstance(inner, SubprocVecEnv) else None  # None: the envs run in this process
    if workers is not None:
        workers.waiting = False
    try:
        envs.close()
    except (EOFError, OSError) as error:  # OSError covers ConnectionResetError and BrokenPipeError
        print(f"warning: an env worker had already stopped ({type(error).__name__}); terminating the rest")
        if workers is None:
            return
        for process in workers.processes:
            if process.is_alive():
                process.terminate()
            process.join(timeout=5)
        for remote in workers.remotes:
            remote.close()
        workers.closed = True
