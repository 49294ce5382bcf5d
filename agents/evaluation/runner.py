"""Episode tasks that run anywhere: in this process, a local process pool or a Ray worker.

A task names an agent, a sensor factor and its level, and a seed; the worker keeps one env and agent per
(agent, env settings) so that consecutive tasks of a cell do not rebuild the MuJoCo model or GL context.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from agents.evaluation.episode import EpisodeRecord, run_episode
from agents.evaluation.records import append_record, completed_keys, read_records
from agents.policies import agent_env_kwargs, load_agent


@dataclass(frozen=True)
class EpisodeTask:
    """One episode to fly: who, with which env kwargs, from which seed; ``factor``/``level`` label the record."""

    agent: str
    factor: str
    level: float
    seed: int
    env_id: str = "FlowNav-v0"
    env_kwargs: tuple[tuple[str, Any], ...] = ()
    policy: str | None = None  # a learned agent's .zip; None: results/policies/<agent>.zip
    bee_params: tuple[tuple[str, float], ...] = field(default=())

    def env_settings(self) -> dict[str, Any]:
        """The env kwargs to fly with: the agent's own (a learned agent keeps what it was trained with, such
        as oracle observations), then this task's on top."""
        return {**agent_env_kwargs(self.agent, self.policy), **dict(self.env_kwargs)}


def episode_step_limit(env_id: str, settings: Mapping[str, Any]) -> int | None:
    """A time limit that scales with speed: twice the time the course takes at the commanded speed.

    Registered limits assume the default 0.1 m per frame; slower flights (a sweep's forward-speed levels)
    would otherwise be cut off before they could reach the goal. None keeps the registered limit.
    """
    if "forward_speed" not in settings:
        return None
    import gymnasium as gym

    spec = gym.spec(env_id)
    defaults = {**spec.kwargs, **settings}
    speed = max(float(defaults["forward_speed"]), 0.1)
    length = float(defaults.get("field_length", 20.0))
    frame_rate = float(defaults.get("frame_rate", 10.0))
    return max(spec.max_episode_steps or 0, math.ceil(2.0 * length / speed * frame_rate))


_CACHE: dict[tuple, tuple[Any, Any]] = {}


def _env_and_agent(task: EpisodeTask) -> tuple[Any, Any]:
    import gymnasium as gym

    import flownav_env  # noqa: F401  (registers the ids in this worker)

    settings = task.env_settings()
    # JSON, not a tuple of items: settings may nest (estimator_kwargs) and dicts do not hash.
    key = (
        task.agent,
        task.env_id,
        json.dumps(settings, sort_keys=True, default=str),
        task.policy,
        task.bee_params,
    )
    if key not in _CACHE:
        for env, _ in _CACHE.values():
            env.close()
        _CACHE.clear()
        limit = episode_step_limit(task.env_id, settings)
        env = gym.make(task.env_id, **settings, **({"max_episode_steps": limit} if limit else {}))
        _CACHE[key] = (env, load_agent(task.agent, task.policy, **dict(task.bee_params)))
    return _CACHE[key]


def run_task(task: EpisodeTask) -> EpisodeRecord:
    """Fly the task's episode (in whatever process this runs)."""
    import torch

    torch.set_num_threads(1)
    env, agent = _env_and_agent(task)
    return run_episode(env, agent, task.seed, label=task.agent, factor=task.factor, level=task.level)


def pending_tasks(tasks: list[EpisodeTask], csv_path: Path) -> list[EpisodeTask]:
    """The tasks whose episode is not in the CSV yet (what a resumed run still has to fly)."""
    done = completed_keys(read_records(csv_path))
    return [t for t in tasks if (t.agent, t.factor, float(t.level), int(t.seed)) not in done]


def execute(
    tasks: list[EpisodeTask],
    csv_path: Path,
    *,
    backend: str = "local",
    workers: int = 1,
    address: str | None = None,
    description: str = "episodes",
) -> int:
    """Fly every task not yet in ``csv_path``, appending each record as its episode ends.

    Args:
        tasks: the episodes to fly.
        csv_path: the episodes CSV; finished episodes already in it are skipped (resume).
        backend: ``"local"`` (this process when ``workers`` is 1, else a process pool) or ``"ray"``.
        workers: local worker processes.
        address: Ray cluster address (``ray.init(address=...)``); None starts a local Ray instance.
        description: progress-bar label.

    Returns:
        The number of episodes flown in this call.
    """
    from tqdm import tqdm

    if backend not in ("local", "ray"):
        raise ValueError(f"backend must be 'local' or 'ray', got {backend!r}")
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    csv_path = Path(csv_path)
    todo = pending_tasks(tasks, csv_path)
    if not todo:
        return 0
    progress = tqdm(total=len(todo), desc=description, unit="episode")
    try:
        for record in _results(todo, backend, workers, address):
            append_record(csv_path, record)
            progress.update()
    finally:
        progress.close()
    return len(todo)


def _results(todo: list[EpisodeTask], backend: str, workers: int, address: str | None):
    if backend == "ray":
        yield from _ray_results(todo, address, workers)
    elif workers == 1:
        for task in todo:
            yield run_task(task)
    else:
        import multiprocessing

        # forkserver: a forked child would inherit this process's GL state, which hangs EGL.
        context = multiprocessing.get_context("forkserver")
        with context.Pool(workers) as pool:
            # Tasks are ordered by cell, so chunks keep each worker on one env for a while.
            yield from pool.imap_unordered(run_task, todo, chunksize=1)


def _ray_results(todo: list[EpisodeTask], address: str | None, workers: int):
    try:
        import ray
    except ImportError as error:
        raise ValueError("backend 'ray' needs Ray: pip install 'flownav[ray]'") from error
    started_here = not ray.is_initialized()
    if started_here:
        if address:
            ray.init(address=address, log_to_driver=False)
        else:
            ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
    try:
        remote_task = ray.remote(num_cpus=1)(run_task)
        pending = [remote_task.remote(task) for task in todo]
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            yield ray.get(done[0])
    finally:
        if started_here:
            ray.shutdown()
