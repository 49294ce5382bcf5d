"""Several independent training runs of one config, one per training seed (``flownav train --seeds 0-4``).

Seed k is the config with ``seed: k``: PPO's seed and the start of its env workers' layouts
(:func:`agents.common.seeds.training_env_seed`). Its outputs go to ``runs/<name>/seed_<k>/`` and ship to
``results/policies/<name>/seed_<k>.zip`` with config, record, evaluations and curve.

The seeds are independent jobs. The local backend trains them in turn in this process (each with its own env
workers), or ``parallel`` at a time, each in a process of its own that steps its envs itself: on a small
machine that keeps every core stepping an env instead of idling in lock-step; the Ray backend submits each as
a task asking for ``n_envs`` CPUs, so a cluster trains them side by side.
Every job resumes: a seed whose record shows its full budget is skipped, one with checkpoints continues from the
newest, and one without starts fresh. Re-running the same command after an interruption picks up where it
stopped.
"""

from __future__ import annotations

import multiprocessing
import queue
import re
import sys
from collections.abc import Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import yaml

from agents.common.folders import write_text_atomically
from agents.common.interrupts import ignore_ctrl_c, stop_signals_interrupt
from agents.common.process_pool import stop_processes
from agents.common.seeds import MAX_RUN_SEED
from agents.training.outputs import RunFiles
from agents.training.parking import discard, park, parked_files, restore
from agents.training.run_record import interrupted_at
from agents.training.shipping import ship_run
from agents.training.train_config import TrainConfig

if TYPE_CHECKING:
    from multiprocessing.process import BaseProcess
    from multiprocessing.queues import Queue

    from agents.training.imitation import TeacherFactory

# What a seed trained side by side reports: its index, its policy path or None, its error or None.
SeedOutcome = tuple[int, str | None, BaseException | None]

_SEED_ITEM = re.compile(r"^(\d+)(?:-(\d+))?$")
# Most seeds trained at once by the local backend; each wants a core or more.
MAX_PARALLEL_SEEDS = 64


def parse_seeds(text: str) -> list[int]:
    """Training seeds from ``"0-4"``, ``"0,2,7"`` or ``"0-2,5"``, in the order given, without repeats.

    Raises:
        ValueError: an item that is neither ``N`` nor ``N-M`` with N <= M, or a seed outside
            [0, MAX_RUN_SEED].
    """
    seeds: list[int] = []
    for item in str(text).replace(" ", "").split(","):
        match = _SEED_ITEM.match(item)
        if match is None or (match.group(2) is not None and int(match.group(2)) < int(match.group(1))):
            raise ValueError(f"--seeds takes N, N-M (N <= M) or a comma-separated list of them, got {text!r}")
        low = int(match.group(1))
        high = int(match.group(2)) if match.group(2) is not None else low
        if high > MAX_RUN_SEED:
            raise ValueError(
                f"training seeds must lie in [0, {MAX_RUN_SEED}], got {high} in --seeds {text!r}"
            )
        seeds += [seed for seed in range(low, high + 1) if seed not in seeds]
    return seeds


@dataclass(frozen=True)
class SeedJob:
    """One training seed of a config: everything a worker (local or Ray) needs to train it."""

    config: TrainConfig
    source_config: Path
    runs_dir: Path
    ship_to: Path | None
    parked_dir: Path | None = None
    command: str | None = None  # the command line that trains the seeds, for the record
    # Builds the agent a config's ``imitation.teacher`` names; a module-level function, so a job pickles.
    make_teacher: TeacherFactory | None = None

    @property
    def files(self) -> RunFiles:
        return RunFiles.of_seed(self.runs_dir, self.config.name, self.config.seed)

    @property
    def parked(self) -> RunFiles | None:
        """Where this seed is parked, if jobs may be parked at all."""
        if self.parked_dir is None:
            return None
        return parked_files(self.parked_dir, self.config.name, self.config.seed)


def seed_jobs(
    config: TrainConfig,
    seeds: list[int],
    *,
    config_path: Path,
    runs_dir: Path,
    ship_to: Path | None,
    parked_dir: Path | None = None,
    command: str | None = None,
    make_teacher: TeacherFactory | None = None,
) -> list[SeedJob]:
    """One job per seed; a ``ship_to`` policies folder becomes ``ship_to/<name>/`` for the seeds; seeds parked
    in ``parked_dir`` (:mod:`agents.training.parking`) resume from there when their run folder is empty;
    ``command`` is the command line recorded in each seed's record."""
    seed_ship_to = Path(ship_to) / config.name if ship_to is not None else None
    return [
        SeedJob(
            replace(config, seed=seed),
            Path(config_path),
            Path(runs_dir),
            seed_ship_to,
            parked_dir,
            command,
            make_teacher,
        )
        for seed in seeds
    ]


def finished(job: SeedJob) -> bool:
    """Whether the seed's record shows its whole ``total_timesteps`` trained, with its policy written."""
    return job.files.trained_steps() >= job.config.total_timesteps


def write_seed_config(job: SeedJob) -> Path:
    """The seed's own config file in its run folder: the source YAML with ``seed`` set, so that the shipped
    ``seed_<k>.yaml`` says which seed it is (and, for a recipe for every tier, the tier's id and run name)."""
    files = job.files
    files.run_dir.mkdir(parents=True, exist_ok=True)
    mapping = yaml.safe_load(job.source_config.read_text())
    mapping["seed"] = job.config.seed
    tier_option = ""
    if mapping.get("per_tier"):
        # A recipe for every tier, trained for one (train_config.for_tier): the seed's file is that tier's.
        mapping.update(name=job.config.name, env_id=job.config.env_id, per_tier=False)
        tier_option = f" --tiers {job.config.env_id}"
    header = (
        f"# {job.source_config.name} with seed {job.config.seed}, written by\n"
        f"# flownav train --config {job.source_config}{tier_option} --seeds {job.config.seed}\n"
    )
    write_text_atomically(files.config, header + yaml.safe_dump(mapping, sort_keys=False))
    return files.config


def train_seed(job: SeedJob, side_by_side: bool = False) -> Path:
    """Train (or resume, or skip as finished) one seed; returns its policy path.

    ``side_by_side`` is for a seed trained beside others on the same machine: its envs step in its own process
    and it reports progress in lines, not a bar."""
    # ppo imports torch and stable-baselines3: only a process that trains a seed loads them.
    from agents.training.ppo import train

    if job.parked is not None and not finished(job) and restore(job.parked, job.files):
        print(f"seed {job.config.seed}: restored from {job.parked.run_dir} (parked), resuming")
    if finished(job):
        print(f"seed {job.config.seed}: finished ({job.files.policy}); skipping")
        if job.ship_to is not None and not (job.ship_to / job.files.policy.name).is_file():
            ship_run(job.files, job.ship_to)
        return job.files.policy
    config_path = write_seed_config(job)
    policy = train(
        job.config,
        config_path=config_path,
        resume=True,
        runs_dir=job.runs_dir,
        ship_to=job.ship_to,
        files=job.files,
        in_process_envs=side_by_side,
        # A live bar's refresh thread only suits a terminal; in a log (CI, nohup) it printed noise, and a
        # SIGTERM caught it mid-refresh ("deque mutated during iteration") and left the run hanging.
        progress_bar=not side_by_side and sys.stdout.isatty(),
        command=job.command,
        make_teacher=job.make_teacher,
    )
    steps = interrupted_at(job.files)
    if steps is not None:
        # Stop here rather than start the next seed: the same command resumes this one.
        raise KeyboardInterrupt(
            f"seed {job.config.seed} saved at {steps:,} steps in {job.files.run_dir}; run the same command "
            "to resume"
        )
    if job.parked is not None:
        discard(job.parked)
    return policy


def park_seeds(jobs: list[SeedJob]) -> list[Path]:
    """Park every unfinished seed that has a checkpoint (:func:`agents.training.parking.park`); returns the
    parked run folders. Finished seeds and seeds without a checkpoint are passed over with a line each.

    Raises:
        ValueError: a job without a parking folder.
    """
    parked = []
    for job in jobs:
        if job.parked is None:
            raise ValueError(f"seed {job.config.seed}: no parking folder given")
        if finished(job):
            print(f"seed {job.config.seed}: finished; nothing to park (ship it)")
            continue
        try:
            copied = park(job.files, job.parked)
        except FileNotFoundError as error:
            print(f"seed {job.config.seed}: {error}")
            continue
        print(f"seed {job.config.seed}: parked {len(copied)} files in {job.parked.run_dir}")
        parked.append(job.parked.run_dir)
    return parked


def train_seeds(
    jobs: list[SeedJob], *, backend: str = "local", address: str | None = None, parallel: int = 1
) -> list[Path]:
    """Train every job: in turn here (``"local"``), ``parallel`` at a time in local processes, or as parallel
    Ray tasks (``"ray"``); returns the policy paths in job order.

    Raises:
        ValueError: an unknown backend, Ray not installed, or ``parallel`` not an integer in [1, 64] (or
            above 1 with the Ray backend, which schedules by itself).
        KeyboardInterrupt: SIGINT or SIGTERM stopped the training; every running seed saved first.
    """
    if backend not in ("local", "ray"):
        raise ValueError(f"backend must be 'local' or 'ray', got {backend!r}")
    if isinstance(parallel, bool) or not isinstance(parallel, int) or not 1 <= parallel <= MAX_PARALLEL_SEEDS:
        raise ValueError(f"parallel must be an integer in [1, {MAX_PARALLEL_SEEDS}], got {parallel!r}")
    if backend == "ray":
        if parallel != 1:
            raise ValueError(
                f"parallel applies to the local backend only (Ray schedules its tasks), got {parallel}"
            )
        return list(_ray_train(jobs, address))
    if parallel == 1:
        return [train_seed(job) for job in jobs]
    return _train_side_by_side(jobs, min(parallel, len(jobs)))


# How often the parent of seeds side by side looks for one that died without reporting.
RESULT_POLL_S = 5.0
# How long a seed sent SIGTERM after an error in the parent's own loop may take to park its run (a model and its
# record written) before it is killed: a save takes seconds, so this only bounds a seed that hangs.
SEED_STOP_WAIT_S = 60.0


def _died(job: SeedJob, exit_code: int | None) -> str:
    return (
        f"seed {job.config.seed}'s process ended (exit code {exit_code}) without a result; its newest "
        "checkpoint is its resume point: run the same command to resume"
    )


def _seed_process(index: int, job: SeedJob, results: Queue[SeedOutcome]) -> None:
    """One seed trained side by side, in its own process: its outcome goes to ``results`` as ``(index, policy
    path or None, error or None)``."""
    ignore_ctrl_c()
    try:
        results.put((index, str(train_seed(job, side_by_side=True)), None))
    except BaseException as error:  # an interrupted seed raises KeyboardInterrupt; any error goes back too
        results.put((index, None, error))


def _train_side_by_side(jobs: list[SeedJob], parallel: int) -> list[Path]:
    """``parallel`` seeds at a time, each in a forkserver process (EGL cannot render after a fork); one seed
    alone runs so too, as for a seed trained beside another command.

    A process is started for a seed only when one is free, so nothing waits in a queue. The processes ignore
    Ctrl-C (it reaches the whole process group) and, like any run, save and stop on SIGTERM while learning. A
    stop signal here is passed on once, as SIGTERM, to every running seed, which saves; no further seed starts.
    The first error of a seed is raised once the running ones have ended.
    """
    seeds = _SeedProcesses(jobs, parallel)
    try:
        with stop_signals_interrupt():
            while seeds.waiting or seeds.running:
                seeds.start_free()
                if not seeds.running:
                    break
                try:
                    index, policy, error = seeds.results.get(timeout=RESULT_POLL_S)
                except queue.Empty:
                    seeds.reap_silent_deaths()
                    continue
                except KeyboardInterrupt:
                    seeds.stop()
                    continue
                seeds.finish(index, policy, error)
    finally:
        seeds.terminate_running()
    return seeds.policies()


class _SeedProcesses:
    """The seeds of :func:`_train_side_by_side`: those waiting, those running in their process, and the
    outcome of each that ended."""

    def __init__(self, jobs: list[SeedJob], parallel: int) -> None:
        self.jobs, self.parallel = jobs, parallel
        self.context = multiprocessing.get_context("forkserver")
        self.results: Queue[SeedOutcome] = self.context.Queue()
        self.running: dict[int, BaseProcess] = {}
        self.outcomes: dict[int, tuple[str | None, BaseException | None]] = {}
        self.waiting = list(range(len(jobs)))
        self.stopping = False

    def start_free(self) -> None:
        """Start waiting seeds while fewer than ``parallel`` run, unless stopping."""
        while self.waiting and len(self.running) < self.parallel and not self.stopping:
            index = self.waiting.pop(0)
            process = self.context.Process(target=_seed_process, args=(index, self.jobs[index], self.results))
            process.start()
            self.running[index] = process

    def reap_silent_deaths(self) -> None:
        """Record as failed, and stop starting seeds after, any process that died without a word (SIGKILL)."""
        for index, process in list(self.running.items()):
            if not process.is_alive() and self.results.empty():
                self.running.pop(index).join()
                self.outcomes[index] = (None, RuntimeError(_died(self.jobs[index], process.exitcode)))
                self.stopping = True

    def stop(self) -> None:
        """A stop signal, passed on once: SIGTERM to every running seed, which saves its checkpoint and record."""
        if not self.stopping:
            self.stopping = True
            for process in self.running.values():
                process.terminate()

    def finish(self, index: int, policy: str | None, error: BaseException | None) -> None:
        """A seed's result arrived: its process is joined; an error starts no further seed."""
        self.running.pop(index).join()
        self.outcomes[index] = (policy, error)
        self.stopping = self.stopping or error is not None

    def terminate_running(self) -> None:
        """Only processes left after an error in the loop itself are still running here: each is sent SIGTERM
        (it parks its run as an interruption does) and killed if it has not ended within
        :data:`SEED_STOP_WAIT_S`, so an error here never leaves the command waiting without bound."""
        stop_processes(self.running.values(), wait_s=SEED_STOP_WAIT_S)

    def policies(self) -> list[Path]:
        """Every seed's policy in job order; else the first error (a failure before an interruption), or
        KeyboardInterrupt where some seed never started."""
        errors = [error for _, error in self.outcomes.values() if error is not None]
        failures = [error for error in errors if not isinstance(error, KeyboardInterrupt)]
        if failures or errors:
            raise (failures or errors)[0]
        if self.waiting:
            raise KeyboardInterrupt("stopped before every seed had started; run the same command to resume")
        policies = [self.outcomes[index][0] for index in range(len(self.jobs))]
        return [Path(policy) for policy in policies if policy is not None]  # every seed without error has one


def _ray_train(jobs: list[SeedJob], address: str | None) -> Iterator[Path]:
    try:  # Ray is optional (the 'ray' extra): imported only for this backend
        import ray
    except ImportError as error:
        raise ValueError("backend 'ray' needs Ray: pip install 'flownav[ray]'") from error
    started_here = not ray.is_initialized()
    if started_here:
        ray.init(address=address, include_dashboard=False, log_to_driver=True)
    try:
        references = [ray.remote(num_cpus=job.config.n_envs)(train_seed).remote(job) for job in jobs]
        yield from ray.get(references)
    finally:
        if started_here:
            ray.shutdown()
