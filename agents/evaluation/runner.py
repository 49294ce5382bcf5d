"""Flying episode tasks anywhere: in this process, a local process pool or a Ray worker.

The worker keeps one env and agent per (agent, env settings) so that consecutive tasks of a cell do not
rebuild the MuJoCo model or GL context. Which tasks a run still has to fly, and the identity each record is
stamped with, is :mod:`agents.evaluation.episode_tasks`' business. Runs writing one CSV at once share the work: each
local task is claimed under the CSV's lock just before it flies (:mod:`agents.evaluation.claims`), and each
record is appended only if the CSV does not hold its episode yet, so no episode is counted twice.
"""

from __future__ import annotations

import dataclasses
import functools
import multiprocessing
import multiprocessing.util
import os
import signal
import time
from collections.abc import Generator, Iterator
from pathlib import Path
from typing import Any

import gymnasium as gym

import flownav_env  # noqa: F401  (registers the env ids in every worker that imports this module)
from agents.analysis.records import (
    FRESH_FILE_HINT,
    append_record,
    episode_identity,
    read_episodes,
    repair_episodes_header,
)
from agents.common.interrupts import stop_signals_interrupt
from agents.common.machine import code_version, cpu_signature
from agents.common.process_pool import run_in_workers
from agents.evaluation.agent_settings import episode_name, flown_settings, plan_settings
from agents.evaluation.claims import CLAIMED, MINE, claim_episode, release_claim, release_claims
from agents.evaluation.episode import EpisodeRecord, run_episode
from agents.evaluation.episode_tasks import EpisodeTask, canonical_json, resume_plan
from agents.evaluation.progress import EpisodeProgress, PlainProgress, episode_progress, holdings_line
from agents.policies import Agent, load_agent
from agents.policies.agent_limits import AgentLimits, check_step_timeout
from agents.policies.agent_process import IsolatedAgent, end_agent_processes
from flownav_env.limits import episode_step_limit
from flownav_env.tiers import SUITE_VERSION

# How often a run that is done checks whether another run has written the episodes it claimed.
AWAIT_POLL_S = 0.5


class FlightCache:
    """The env and agents a worker process flies with: one env (the settings of the cell it flies) and the
    ``max_agents`` agents flown in it lately. A learned agent written <agent>@all flies layout i with training
    seed i mod k, so consecutive tasks alternate between k policies on the same env, and rebuilding both for
    each episode cost about 0.4 s on an episode of 1 s."""

    def __init__(self, max_agents: int = 16) -> None:
        self.max_agents = max_agents
        self.envs: dict[tuple[str, str], gym.Env] = {}
        self.agents: dict[
            tuple[str, str | None, tuple[tuple[str, float], ...], bool, AgentLimits], Agent
        ] = {}

    def env_and_agent(self, task: EpisodeTask) -> tuple[gym.Env, Agent, dict[str, Any]]:
        """The env and agent that fly ``task``, built only when its env settings or agent are new here, and the
        settings the env flies with (:func:`flown_settings`, checked there)."""
        agent_key = (task.agent, task.policy, task.bee_params, task.trust_pickle, task.agent_limits)
        if agent_key not in self.agents:
            if len(self.agents) >= self.max_agents:
                del self.agents[next(iter(self.agents))]  # the oldest
            self.agents[agent_key] = load_agent(
                task.agent,
                task.policy_path(),
                trust_pickle=task.trust_pickle,
                limits=task.agent_limits,
                **dict(task.bee_params),
            )
        agent = self.agents[agent_key]
        settings = flown_settings(task, agent)
        # JSON, not a tuple of items: settings may nest (estimator_kwargs) and dicts do not hash.
        env_key = (task.env_id, canonical_json(settings))
        if env_key not in self.envs:
            self.clear()
            self.agents[agent_key] = agent
            limit = episode_step_limit(task.env_id, settings)
            self.envs[env_key] = (
                gym.make(task.env_id, max_episode_steps=limit, **settings)
                if limit
                else gym.make(task.env_id, **settings)
            )
        return self.envs[env_key], agent, settings

    def clear(self) -> None:
        """Close the env and forget it and the agents: the next task builds its own."""
        for env in self.envs.values():
            env.close()
        self.envs.clear()
        self.agents.clear()


# This process's cache: a pool or Ray worker imports this module once and flies many tasks with it.
WORKER_CACHE = FlightCache()


@functools.cache
def _code_version() -> str:
    """The code version of this process, read once: it does not change while the process runs."""
    return code_version()


@functools.cache
def _cpu_signature() -> str:
    """This machine's CPU (:func:`~agents.common.machine.cpu_signature`), read once."""
    return cpu_signature()


def run_task(task: EpisodeTask, cache: FlightCache = WORKER_CACHE) -> EpisodeRecord:
    """Fly the task's episode (in whatever process this runs) with ``cache``'s env and agent; the record
    carries the task's identity and the code version of the process that flew it.

    Raises:
        PredictTimeout: an outside agent's ``predict`` ran past the task's ``step_timeout_s``.
    """
    import torch  # heavy, and only a worker that flies needs it

    torch.set_num_threads(1)
    env, agent, settings = cache.env_and_agent(task)
    if isinstance(agent, IsolatedAgent):
        agent.step_timeout_s, agent.episode = task.step_timeout_s, episode_name(task)
    record = run_episode(env, agent, task.seed, label=task.agent, factor=task.factor, level=task.level)
    identity = task.identity()
    identity["env_kwargs"] = canonical_json(settings)  # what flew, as it flew
    return dataclasses.replace(
        record,
        **identity,
        code_version=_code_version(),
        suite_version=task.suite_version,
        isolation=agent.limits.isolation if isinstance(agent, IsolatedAgent) else "",
        cpu=_cpu_signature(),
    )


def run_claimed_task(csv_path: Path, task: EpisodeTask) -> tuple[EpisodeTask, str, EpisodeRecord | None]:
    """Fly the task if this process gets its claim on ``csv_path`` (:func:`claim_episode`); returns the task,
    what the claim found, and the record (None when the episode was left to the CSV or another run). A flight
    that fails gives its claim up, so another run need not wait for it to expire."""
    identity = episode_identity({**vars(task), **task.identity()})
    found = claim_episode(csv_path, identity)
    if found != MINE:
        return task, found, None
    try:
        return task, found, run_task(task)
    except BaseException:
        release_claim(csv_path, identity)
        raise


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
    remedy: str = FRESH_FILE_HINT,
    step_timeout_s: float = 0.0,
    by_factor: bool = False,
    agent_limits: AgentLimits | None = None,
) -> int:
    """Fly every task not yet in ``csv_path``, appending each record as its episode ends.

    Before flying, a damaged header is repaired (its checksummed rows kept), and damaged rows and rows of
    another suite version are counted in a line each: their episodes are flown again.

    Args:
        tasks: the episodes to fly.
        csv_path: the episodes CSV; episodes already in it with the same settings are skipped (resume).
        backend: ``"local"`` (this process when ``workers`` is 1, else a process pool) or ``"ray"``.
        workers: local worker processes.
        address: Ray cluster address (``ray.init(address=...)``); None starts a local Ray instance.
        description: progress-bar label.
        remedy: what the command offers when the CSV cannot be resumed (see :func:`resume_plan`).
        step_timeout_s: the most an outside agent's ``predict`` may take per call; 0 for no limit.
        by_factor: say first what the CSV holds of each factor (a suite's tiers), and give each its bar.
        agent_limits: the memory and CPU time an outside agent's process may use (default
            :class:`AgentLimits`'s).

    Returns:
        The number of episodes flown and added in this call (not those another run flew meanwhile).

    Raises:
        ValueError: a bad backend, worker count or step timeout, or a CSV that cannot be resumed (see
            :func:`resume_plan`).
        PredictTimeout: an outside agent's ``predict`` ran past ``step_timeout_s``; the run stops, its claims
            are given up and that episode is not recorded.
        EpisodesInterrupted: Ctrl-C or SIGTERM (a scheduler, ``kill``, the end of a session); the workers are
            stopped, the episodes flown so far are kept, and the message says how many are in the CSV and how
            to resume.
    """
    _check_run_options(backend, workers, step_timeout_s)
    csv_path = Path(csv_path)
    if (repaired := repair_episodes_header(csv_path)) is not None:
        print(repaired)
    plan = resume_plan(tasks, csv_path, remedy)
    _say_what_does_not_count(csv_path, plan.damaged, plan.other_versions)
    limits = agent_limits or AgentLimits()
    todo = plan_settings(
        [dataclasses.replace(task, step_timeout_s=step_timeout_s, agent_limits=limits) for task in plan.todo]
    )
    if by_factor:
        print(holdings_line(csv_path, tasks, todo))
    if not todo:
        return 0
    progress = episode_progress(todo, description, by_factor=by_factor)
    results = _results(todo, csv_path, backend, workers, address)
    flown = 0
    try:
        # SIGTERM too: killed mid-sweep, the parent would die with its pool's workers still sending results
        # into a closed pipe, each printing a traceback.
        with stop_signals_interrupt():
            elsewhere: list[EpisodeTask] = []
            for task, found, record in results:
                # Only a claiming backend says CLAIMED, and it names the task.
                if found == CLAIMED and task is not None:
                    elsewhere.append(task)
                    continue
                flown += record is not None and append_record(csv_path, record)
                progress.update(record.factor if record is not None else task.factor if task else None)
            flown += _await_other_runs(elsewhere, csv_path, progress)
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
        release_claims(csv_path)
        end_agent_processes()  # an outside agent's process, and all it started, ends with the run
    if flown < len(todo):
        print(
            f"{len(todo) - flown} of these episodes were flown by another run writing {csv_path} at the same "
            "time; each is in the file once"
        )
    return flown


def _check_run_options(backend: str, workers: int, step_timeout_s: float) -> None:
    """Refuse a backend, worker count or step timeout :func:`execute` cannot run with, before any file is read."""
    if backend not in ("local", "ray"):
        raise ValueError(f"backend must be 'local' or 'ray', got {backend!r}")
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    check_step_timeout(step_timeout_s)


def _say_what_does_not_count(csv_path: Path, damaged: int, other_versions: dict[str, int]) -> None:
    """A line for the damaged rows of ``csv_path`` and one for its rows of another suite version: both are
    left out, and any of this run's episodes among them is flown again."""
    if damaged:
        print(
            f"{damaged} damaged rows in {csv_path} (torn, or failing their checksum) are left out; "
            "their episodes will be flown again"
        )
    for version, count in other_versions.items():
        print(
            f"{count} rows in {csv_path} were flown under suite version {version!r}, not the current "
            f"{SUITE_VERSION!r}: they are left out and their episodes flown again"
        )


def _await_other_runs(
    tasks: list[EpisodeTask], csv_path: Path, progress: EpisodeProgress | PlainProgress
) -> int:
    """Wait until the episodes another run claimed are in the CSV, so this run's report counts them too;
    fly here any whose claimant stopped without writing it. Returns the number flown here."""
    flown = 0
    while tasks:
        waiting = []
        for task in tasks:
            _, found, record = run_claimed_task(csv_path, task)
            if found == CLAIMED:
                waiting.append(task)
                continue
            flown += record is not None and append_record(csv_path, record)
            progress.update(task.factor)
        if waiting:
            progress.set_postfix_str(f"waiting for {len(waiting)} episodes another run is flying")
            time.sleep(AWAIT_POLL_S)
        tasks = waiting
    return flown


def _start_pool_worker() -> None:
    """Pool workers leave Ctrl-C to the parent, which stops them; else each prints its own traceback. SIGTERM,
    how the parent stops them (:func:`~agents.common.process_pool.run_in_workers`), ends the worker's outside agent processes first, as its
    normal exit does."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _end_pool_worker)
    multiprocessing.util.Finalize(None, end_agent_processes, exitpriority=10)


def _end_pool_worker(signum: int, frame: object) -> None:
    end_agent_processes()
    os._exit(128 + signum)


def _results(
    todo: list[EpisodeTask], csv_path: Path, backend: str, workers: int, address: str | None
) -> Generator[tuple[EpisodeTask | None, str, EpisodeRecord | None], None, None]:
    """(task, what its claim found, its record) per task; the task only where it is needed (CLAIMED)."""
    if backend == "ray":  # Ray workers may not see this machine's files: the append check alone guards
        for record in _ray_results(todo, address, workers):
            yield None, MINE, record
    elif workers == 1:
        for task in todo:
            yield run_claimed_task(csv_path, task)
    else:
        # Tasks are ordered by cell, so each worker stays on one env for a while.
        yield from run_in_workers(
            functools.partial(run_claimed_task, csv_path),
            todo,
            workers,
            initializer=_start_pool_worker,
            describe=episode_name,
        )


def _ray_results(todo: list[EpisodeTask], address: str | None, workers: int) -> Iterator[EpisodeRecord]:
    try:
        import ray  # optional (the flownav[ray] extra), and heavy
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
