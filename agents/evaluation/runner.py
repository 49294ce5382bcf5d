"""Episode tasks that run anywhere: in this process, a local process pool or a Ray worker.

A task names an agent, a sensor factor and its level, and a seed; the worker keeps one env and agent per
(agent, env settings) so that consecutive tasks of a cell do not rebuild the MuJoCo model or GL context.
Every record is stamped with its task's identity (env id, full env settings, agent parameters, policy hash)
and the code version; a resumed run skips only episodes flown with the same identity and refuses a CSV whose
rows were flown with other settings under the same (agent, factor, level, seed).
"""

from __future__ import annotations

import dataclasses
import functools
import json
import signal
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from agents.common.machine import code_version
from agents.common.paths import POLICIES_DIR
from agents.evaluation.csv_file import move_aside
from agents.evaluation.episode import EpisodeRecord, run_episode
from agents.evaluation.records import (
    IDENTITY_FIELDS,
    OVERWRITE_HINT,
    append_record,
    episode_key,
    predates_identities,
    read_episodes,
    row_identity,
)
from agents.policies import (
    agent_env_kwargs,
    agent_parameters,
    is_learned,
    load_agent,
    policy_file,
    split_agent_name,
)
from agents.training.interrupts import stop_signals_interrupt
from agents.training.manifest import file_sha256
from flownav_env.limits import episode_step_limit


def canonical_json(value: Any) -> str:
    """``value`` as JSON with sorted keys and no spaces: equal settings give equal text."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"), default=str)


_HASHES: dict[tuple[str, int, int], str] = {}


def cached_file_sha256(path: Path) -> str:
    """:func:`~agents.training.manifest.file_sha256` of the file ("" if there is none), cached while its size
    and mtime stay the same: every episode record carries its policy's hash."""
    try:
        stat = path.stat()
    except OSError:
        return ""
    key = (str(path.resolve()), stat.st_mtime_ns, stat.st_size)
    if key not in _HASHES:
        _HASHES[key] = file_sha256(path)
    return _HASHES[key]


def record_label(env_kwargs: dict[str, Any]) -> tuple[str, float]:
    """(factor, level) of the records flown with ``env_kwargs``: ``clean`` for defaults, the kwarg and its value
    for one numeric setting (as in the sweep), else every setting spelled out, so different settings never share
    a row key."""
    if not env_kwargs:
        return "clean", 0.0
    if len(env_kwargs) == 1:
        ((key, value),) = env_kwargs.items()
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return key, float(value)
    return ",".join(f"{k}={v}" for k, v in sorted(env_kwargs.items())), 0.0


@dataclass(frozen=True)
class EpisodeTask:
    """One episode to fly: who, with which env kwargs, from which seed; ``factor``/``level`` label the record."""

    agent: str
    factor: str
    level: float
    seed: int
    env_id: str = "FlowNav-v0"
    env_kwargs: tuple[tuple[str, Any], ...] = ()
    policy: str | None = None  # a learned agent's .zip; None: its file in <repo>/results/policies/
    bee_params: tuple[tuple[str, float], ...] = field(default=())

    def policy_path(self) -> Path | None:
        """The learned agent's policy file (wherever the command runs from); None for reactive agents."""
        if not is_learned(self.agent):
            return None
        return policy_file(self.agent, self.policy, directory=POLICIES_DIR)

    def env_settings(self) -> dict[str, Any]:
        """The env kwargs to fly with: the agent's own (a learned agent keeps what it was trained with, such
        as oracle observations), then this task's on top."""
        return {**agent_env_kwargs(self.agent, self.policy_path()), **dict(self.env_kwargs)}

    def identity(self) -> dict[str, str]:
        """What defines this task's episode beyond its (agent, factor, level, seed): the
        :data:`~agents.evaluation.records.IDENTITY_FIELDS` its record carries."""
        policy = self.policy_path()
        return {
            "env_id": self.env_id,
            "env_kwargs": canonical_json(self.env_settings()),
            "agent_params": canonical_json(agent_parameters(self.agent, **dict(self.bee_params))),
            "policy_sha256": "" if policy is None else cached_file_sha256(policy),
        }


def _identities(tasks: list[EpisodeTask]) -> list[tuple[str, ...]]:
    """Each task's identity as a tuple in IDENTITY_FIELDS order, computed once per distinct setting (a sweep
    has thousands of tasks but only agents × cells settings, and a learned agent's reads files)."""
    cache: dict[str, tuple[str, ...]] = {}
    result = []
    for task in tasks:
        setting = canonical_json([task.agent, task.env_id, task.env_kwargs, task.policy, task.bee_params])
        if setting not in cache:
            identity = task.identity()
            cache[setting] = tuple(identity[name] for name in IDENTITY_FIELDS)
        result.append(cache[setting])
    return result


# One env per worker (the settings of the cell it flies) and the agents flown in it lately: a learned agent
# written <agent>@all flies layout i with training seed i mod k, so consecutive tasks alternate between k
# policies on the same env, and rebuilding both for each episode cost about 0.4 s on an episode of 1 s.
_ENV: dict[tuple, Any] = {}
_AGENTS: dict[tuple, Any] = {}
MAX_CACHED_AGENTS = 16


def _env_and_agent(task: EpisodeTask) -> tuple[Any, Any]:
    import gymnasium as gym

    import flownav_env  # noqa: F401  (registers the ids in this worker)

    settings = task.env_settings()
    # JSON, not a tuple of items: settings may nest (estimator_kwargs) and dicts do not hash.
    env_key = (task.env_id, canonical_json(settings))
    if env_key not in _ENV:
        for env in _ENV.values():
            env.close()
        _ENV.clear()
        limit = episode_step_limit(task.env_id, settings)
        _ENV[env_key] = gym.make(task.env_id, **settings, **({"max_episode_steps": limit} if limit else {}))
    agent_key = (task.agent, task.policy, task.bee_params)
    if agent_key not in _AGENTS:
        if len(_AGENTS) >= MAX_CACHED_AGENTS:
            del _AGENTS[next(iter(_AGENTS))]  # the oldest
        _AGENTS[agent_key] = load_agent(task.agent, task.policy_path(), **dict(task.bee_params))
    return _ENV[env_key], _AGENTS[agent_key]


@functools.lru_cache(maxsize=1)
def _code_version() -> str:
    return code_version()


def run_task(task: EpisodeTask) -> EpisodeRecord:
    """Fly the task's episode (in whatever process this runs); the record carries the task's identity and
    the code version of the process that flew it."""
    import torch

    torch.set_num_threads(1)
    env, agent = _env_and_agent(task)
    record = run_episode(env, agent, task.seed, label=task.agent, factor=task.factor, level=task.level)
    return dataclasses.replace(record, **task.identity(), code_version=_code_version())


def pending_tasks(tasks: list[EpisodeTask], csv_path: Path) -> list[EpisodeTask]:
    """The tasks whose episode is not in the CSV yet (what a resumed run still has to fly).

    Raises:
        ValueError: the CSV predates episode identities, or holds an episode of one of the tasks flown with
            other settings (resuming would mix the two), or two tasks share a key but not their settings.
    """
    csv_path = Path(csv_path)
    episodes = read_episodes(csv_path)
    if episodes.legacy:
        raise ValueError(predates_identities(csv_path))
    identities = _identities(tasks)
    wanted: dict[tuple, tuple[str, ...]] = {}
    for task, identity in zip(tasks, identities, strict=True):
        key = episode_key(vars(task))
        if wanted.setdefault(key, identity) != identity:
            raise ValueError(f"two tasks are episode {_describe(key)} but with different settings")
    flown: dict[tuple, set[tuple[str, ...] | None]] = {}
    for row in episodes.rows:
        flown.setdefault(episode_key(row), set()).add(row_identity(row))
    todo = []
    for task, identity in zip(tasks, identities, strict=True):
        found = flown.get(episode_key(vars(task)), set())
        if identity in found:
            continue
        if found:
            raise ValueError(_conflict(csv_path, episode_key(vars(task)), identity, found))
        todo.append(task)
    return todo


def set_aside_stale_episodes(tasks: list[EpisodeTask], csv_path: Path, why: str) -> Path | None:
    """Move ``csv_path`` aside (``<name>.bak-<time>``) when it holds an episode of one of ``tasks`` flown with
    other settings, and say so with ``why``; returns where it went, or None when nothing was stale.

    For episodes that only ever stand for the current code's agent (a re-tuned reactive reference, a run's
    current finalists), where :func:`pending_tasks` would refuse to mix them. Nothing is deleted.
    """
    csv_path = Path(csv_path)
    if not csv_path.is_file():
        return None
    wanted = {
        episode_key(vars(task)): identity for task, identity in zip(tasks, _identities(tasks), strict=True)
    }
    stale = sorted(
        {
            str(row["agent"])
            for row in read_episodes(csv_path).rows
            if episode_key(row) in wanted and row_identity(row) != wanted[episode_key(row)]
        }
    )
    if not stale:
        return None
    backup = move_aside(csv_path)
    print(
        f"{csv_path} holds episodes of {', '.join(stale)} flown with other settings ({why}); moved to {backup}"
    )
    return backup


def _describe(key: tuple[str, str, float, int]) -> str:
    agent, factor, level, seed = key
    return f"({agent}, {factor}, level {level:g}, seed {seed})"


def _conflict(path: Path, key: tuple, identity: tuple[str, ...], found: set) -> str:
    there = next(iter(found))
    differences = ", ".join(
        f"{name} {old!r} there, {new!r} now"
        for name, old, new in zip(IDENTITY_FIELDS, there or (None,) * len(identity), identity, strict=True)
        if old != new
    )
    retrained = "policy_sha256" in differences
    return (
        f"{path} already holds episode {_describe(key)} flown with other settings ({differences}); "
        f"resuming would mix them. To fly these settings, {OVERWRITE_HINT}"
        + (
            f"; after retraining, flownav sweep --refly {key[0]} flies just that agent again"
            if retrained
            else ""
        )
    )


def pooled_over_training_seeds(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Rows with each learned agent's training seeds (``ppo_flow@3``) relabelled as the agent, so that a
    summary gives the agent one row over its seeds."""
    return [{**row, "agent": split_agent_name(row["agent"])[0]} for row in rows]


def rows_of(tasks: list[EpisodeTask], rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The rows that are episodes of ``tasks``: same (agent, factor, level, seed) and the same identity, or
    an unknown one (a CSV from before identities), so a report never mixes in episodes of other settings."""
    wanted = {
        episode_key(vars(task)): identity for task, identity in zip(tasks, _identities(tasks), strict=True)
    }
    return [
        row
        for row in rows
        if episode_key(row) in wanted and row_identity(row) in (None, wanted[episode_key(row)])
    ]


class EpisodesInterrupted(KeyboardInterrupt):
    """Ctrl-C or SIGTERM during :func:`execute`: the episodes flown so far are on disk; the message says where
    and how to resume (``flownav`` prints it as ``interrupted: <message>`` and exits 130). A KeyboardInterrupt, so
    code that does not know it still stops."""


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
        csv_path: the episodes CSV; episodes already in it with the same settings are skipped (resume).
        backend: ``"local"`` (this process when ``workers`` is 1, else a process pool) or ``"ray"``.
        workers: local worker processes.
        address: Ray cluster address (``ray.init(address=...)``); None starts a local Ray instance.
        description: progress-bar label.

    Returns:
        The number of episodes flown in this call.

    Raises:
        ValueError: a bad backend or worker count, or a CSV that cannot be resumed (see :func:`pending_tasks`).
        EpisodesInterrupted: Ctrl-C or SIGTERM (a scheduler, ``kill``, the end of a session); the workers are
            stopped, the episodes flown so far are kept, and the message says how many are in the CSV and how
            to resume.
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
    results = _results(todo, backend, workers, address)
    flown = 0
    try:
        # SIGTERM too: killed mid-sweep, the parent would die with its pool's workers still sending results
        # into a closed pipe, each printing a traceback.
        with stop_signals_interrupt():
            for record in results:
                append_record(csv_path, record)
                flown += 1
                progress.update()
    except KeyboardInterrupt:
        results.close()  # stops the pool or Ray before the message, whichever line Ctrl-C hit
        progress.close()
        stored = len(read_episodes(csv_path).rows)
        raise EpisodesInterrupted(
            f"{stored} episodes are in {csv_path} ({flown} of {len(todo)} flown in this run); "
            "run the same command again to resume"
        ) from None
    finally:
        results.close()
        progress.close()
    return len(todo)


def _ignore_interrupts() -> None:
    """Pool workers leave Ctrl-C to the parent, which stops them; else each prints its own traceback. SIGTERM
    keeps its default: it is how the parent's ``pool.terminate()`` stops them."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _results(
    todo: list[EpisodeTask], backend: str, workers: int, address: str | None
) -> Iterator[EpisodeRecord]:
    if backend == "ray":
        yield from _ray_results(todo, address, workers)
    elif workers == 1:
        for task in todo:
            yield run_task(task)
    else:
        import multiprocessing

        # forkserver: a forked child would inherit this process's GL state, which hangs EGL.
        context = multiprocessing.get_context("forkserver")
        pool = context.Pool(workers, initializer=_ignore_interrupts)
        try:
            # Tasks are ordered by cell, so chunks keep each worker on one env for a while.
            yield from pool.imap_unordered(run_task, todo, chunksize=1)
            pool.close()
        finally:
            pool.terminate()  # also on Ctrl-C or close(): no worker flies on unseen
            pool.join()


def _ray_results(todo: list[EpisodeTask], address: str | None, workers: int) -> Iterator[EpisodeRecord]:
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
    pending: list[Any] = []
    try:
        remote_task = ray.remote(num_cpus=1)(run_task)
        pending = [remote_task.remote(task) for task in todo]
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            yield ray.get(done[0])
    finally:
        for reference in pending:  # a cluster we did not start would otherwise fly them on
            ray.cancel(reference, force=True)
        if started_here:
            ray.shutdown()
