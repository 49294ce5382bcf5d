"""The benchmark's sweep: every agent under each sensor error at several levels, on the same held-out seeds.

Each (agent, factor, level) cell flies the same seeds, so agents and levels are compared on identical
obstacle layouts. Episodes are appended to ``<out>/sweep_episodes.csv`` as they end (re-running resumes);
the summary goes to ``<out>/sweep.csv`` (collision and success rates with Wilson 95 % intervals); the page and
figure written from what :func:`run_sweep` returns are :mod:`agents.pages.sweep_report`'s.

After a policy is retrained, ``--agents AGENT[,AGENT] --refly`` deletes that agent's episodes so they are flown again;
``--overwrite`` moves the episodes CSV aside (``sweep_episodes.csv.bak-<time>``) and starts a new one, the way
out when the CSV holds episodes flown with other settings (resuming refuses to mix them) or predates them;
``--compare-with OLD/sweep_episodes.csv`` sets each cell of the page beside an earlier sweep's.

Backends: a local process pool (default) or Ray (``--backend ray [--address ADDR]``), the same tasks either way.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from agents.analysis.episode_record import EpisodeRow, PooledRow
from agents.analysis.records import (
    drop_agents,
    overwrite_hint,
    read_episodes,
    start_new_file,
)
from agents.analysis.statistics import RUN_KEY, CellSummary, format_summary
from agents.common.folders import check_writable_folder
from agents.common.locations import REPO_ROOT
from agents.common.seeds import TEST_SEED_START
from agents.common.yaml_config import field_range, load_config
from agents.evaluation.episode_tasks import EpisodeTask, pending_tasks, rows_of
from agents.evaluation.runner import execute
from agents.evaluation.sweep_factors import SWEEP_FACTORS, factor_settings
from agents.evaluation.sweep_summary import write_summary
from agents.policies import (
    LEARNED_AGENTS,
    is_learned,
    is_per_tier,
    policy_file,
    shipped_seed_runs,
    split_agent_name,
)
from flownav_env.settings_check import check_env_kwargs
from flownav_env.tiers import tier_of_env_id

# ``ppo_flow@all`` in a sweep's agents: every shipped training seed of ppo_flow, in turn over the layouts.
ALL_SEEDS = "@all"
# What the sweep offers when its CSV cannot be resumed: its own --overwrite, or --refly for a retrained agent.
SWEEP_REMEDY = f"{overwrite_hint('folder')}; after retraining an agent, --agents AGENT --refly flies just its episodes again"


@dataclass
class SweepConfig:
    """A sweep. ``factors`` maps each FlowNavEnv sensor or course kwarg to its levels beyond the clean setting.

    A relative ``policy_dir`` is resolved against the repository root, not the working directory, so the
    same config finds the shipped policies wherever the command runs from.
    """

    agents: list[str]
    factors: dict[str, list[float]]
    env_id: str = "FlowNav-v0"
    env: dict[str, Any] = field(default_factory=dict)
    episodes: int = field_range(1, 100_000, default=100)
    seed_block: int = field_range(1, 100_000, default=25)
    seed_start: int = field_range(TEST_SEED_START, None, default=TEST_SEED_START)
    workers: int = field_range(1, 256, default=2)
    backend: Literal["local", "ray"] = "local"
    policy_dir: str = "results/policies"
    # A <learned>@all flies its first this many shipped training seeds (0: every one), so that seeds shipped
    # after the sweep was flown leave its layout-to-seed rotation, and so its episodes, as they were.
    training_seeds: int = field_range(0, 1_000, default=0)

    def validate(self) -> None:
        for agent in self.agents:
            base, _, suffix = agent.partition(ALL_SEEDS)
            if suffix or (agent.endswith(ALL_SEEDS) and base not in LEARNED_AGENTS):
                raise ValueError(
                    f"key 'agents': {agent!r}: '{ALL_SEEDS}' follows a learned agent's name, e.g. ppo_flow{ALL_SEEDS}"
                )
            try:
                split_agent_name(base)
            except ValueError as error:
                raise ValueError(f"key 'agents': {error}") from None
        for factor, levels in self.factors.items():
            if factor not in SWEEP_FACTORS:
                raise ValueError(
                    f"key 'factors.{factor}': not a sweep factor (allowed: {', '.join(SWEEP_FACTORS)})"
                )
            if (
                not isinstance(levels, list)
                or not levels
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in levels)
            ):
                raise ValueError(
                    f"key 'factors.{factor}' must be a non-empty list of numbers, got {levels!r}"
                )
            for index, level in enumerate(levels):
                # At load, not when a worker reaches the cell thousands of episodes later.
                try:
                    factor_settings(factor, level)
                except ValueError as error:
                    raise ValueError(f"key 'factors.{factor}[{index}]': {error}") from None

    def policy_folder(self) -> Path:
        """``policy_dir`` as a path; a relative one is taken from the repository root."""
        folder = Path(self.policy_dir)
        return folder if folder.is_absolute() else REPO_ROOT / folder


def seed_rotation(config: SweepConfig, agent: str) -> list[str]:
    """The runs that fly an agent's episodes: the agent itself, or for ``<learned>@all`` each of its shipped
    training seeds in turn (``ppo_flow@0``, ``ppo_flow@1``, ...), the first ``training_seeds`` of them when
    that is set; empty when it has none."""
    if not agent.endswith(ALL_SEEDS):
        return [agent]
    base = agent[: -len(ALL_SEEDS)]
    runs = shipped_seed_runs(base, config.policy_folder())
    return runs[: config.training_seeds] if config.training_seeds else runs


def pool_seeds(rows: Sequence[EpisodeRow], agents: Sequence[str]) -> list[PooledRow]:
    """Rows with each training seed of a ``<learned>@all`` agent relabelled as that agent, so that a cell's
    rate pools its seeds."""
    pooled = {agent[: -len(ALL_SEEDS)] for agent in agents if agent.endswith(ALL_SEEDS)}
    relabelled: list[PooledRow] = []
    for row in rows:
        base, seed = split_agent_name(row["agent"])
        pooled_row: PooledRow = {**row, "agent": base + ALL_SEEDS, RUN_KEY: row["agent"]}
        relabelled.append(pooled_row if seed is not None and base in pooled else PooledRow(**row))
    return relabelled


def pool_every_seed(rows: Sequence[EpisodeRow]) -> list[PooledRow]:
    """:func:`pool_seeds` for episodes read without their sweep config: every learned agent flown by training
    seed (``ppo_flow@3``) is pooled as ``ppo_flow@all``, so that a rate is over its runs and layouts, never one
    seed's few layouts of a cell."""
    seeded = {split_agent_name(row["agent"]) for row in rows}
    return pool_seeds(rows, sorted({base + ALL_SEEDS for base, seed in seeded if seed is not None}))


def build_tasks(config: SweepConfig, agents: list[str]) -> list[EpisodeTask]:
    """Every (agent, factor, level, seed) episode, in passes of ``config.seed_block`` seeds.

    A ``<learned>@all`` agent flies layout i of every cell with its training seed number i modulo the seed
    count: each cell still has ``episodes`` distinct layouts, every training seed flies an equal share of them,
    and the pooled rate estimates the agent over both its training runs and the layouts.

    Each pass flies its seeds in every cell (the clean setting first, then the factors in config order) and,
    within a cell, for every agent. A sweep cut short therefore has every cell at nearly the same count and
    has compared all agents on the same layouts; a ``seed_block`` of at least ``episodes`` flies the cells one
    after the other instead. Within a cell an agent's seeds run in a row, so a worker keeps its env.
    """
    seeds = range(config.seed_start, config.seed_start + config.episodes)
    passes = [seeds[start : start + config.seed_block] for start in range(0, len(seeds), config.seed_block)]
    cells: list[tuple[str, float, dict[str, object]]] = [("clean", 0.0, dict(config.env))]
    for factor, levels in config.factors.items():
        cells += [
            (factor, float(level), {**config.env, **factor_settings(factor, level)}) for level in levels
        ]
    rotations = {agent: seed_rotation(config, agent) for agent in agents}
    tier = tier_of_env_id(config.env_id)

    def task(agent: str, factor: str, level: float, kwargs: Mapping[str, object], seed: int) -> EpisodeTask:
        runs = rotations[agent]
        name = runs[(seed - config.seed_start) % len(runs)]
        # An agent learned once per tier flies the policy of the tier the sweep flies (on an id that is no
        # tier's, its first tier's: the tiers' recipe is one).
        tier_name = tier[1].name if tier is not None and is_per_tier(name) else None
        policy = (
            str(policy_file(name, directory=config.policy_folder(), tier=tier_name))
            if is_learned(name)
            else None
        )
        settings = tuple((setting, kwargs[setting]) for setting in sorted(kwargs))
        return EpisodeTask(name, factor, level, seed, config.env_id, settings, policy)

    return [
        task(agent, factor, level, kwargs, seed)
        for seed_pass in passes
        for factor, level, kwargs in cells
        for agent in agents
        for seed in seed_pass
    ]


@dataclass(frozen=True)
class SweepFlight:
    """What :func:`run_sweep` flew (or found, report-only) and summarised in its folder, for its page.

    Attributes:
        folder: the sweep's folder (its episodes CSV and ``sweep.csv``).
        config: the sweep's config with the command line's overrides; ``config_path`` the file it was read from.
        table: the summary, one row per (agent, factor, level) cell (``sweep.csv``).
        rows: the episodes summarised, each ``<learned>@all`` agent's seeds pooled.
        agents: the config's agents that could fly.
        minutes: the wall time of this invocation; None for a report-only one.
        compare_with: an earlier sweep's episodes CSV to set each cell beside.
    """

    folder: Path
    config: SweepConfig
    config_path: Path
    table: list[CellSummary]
    rows: list[PooledRow]
    agents: list[str]
    minutes: float | None
    compare_with: Path | None


def run_sweep(
    config_path: Path,
    out: Path,
    *,
    overrides: Mapping[str, int | str] | None = None,
    refly: list[str] | None = None,
    compare_with: Path | None = None,
    report_only: bool = False,
    overwrite: bool = False,
    address: str | None = None,
) -> SweepFlight:
    """Fly every episode of the sweep in ``config_path`` not yet in ``<out>/sweep_episodes.csv``, then write
    ``sweep.csv``; returns what its page is written from (:func:`agents.pages.sweep_report.write_sweep_page`).

    Args:
        config_path: the sweep's YAML (:class:`SweepConfig`).
        out: folder of the episodes CSV and the summary.
        overrides: config fields to replace (``episodes``, ``workers``, ``backend``).
        refly: agents whose episodes are deleted first, so they are flown again.
        compare_with: an earlier sweep's episodes CSV to set each cell beside.
        report_only: fly nothing, summarise the episodes flown so far.
        overwrite: move the episodes CSV to ``sweep_episodes.csv.bak-<time>`` first and start a new one.
        address: Ray cluster address.

    Raises:
        ValueError / FileNotFoundError: bad config, overrides, agents or files, or an episodes CSV that cannot
            be resumed (episodes of other settings, or from before episode identities); the message says which.
        EpisodesInterrupted: Ctrl-C while flying; the episodes flown so far are kept.
    """
    config = _load_sweep_config(config_path, overrides)
    agents = _agents_with_policies(config)
    refly = refly or []
    _check_flags(config, config_path, refly, compare_with, report_only, overwrite)
    episodes_csv = _prepare_episodes_csv(out, overwrite)
    started = time.perf_counter()
    tasks = build_tasks(config, agents)
    if refly:
        _delete_refly_episodes(config, tasks, refly, episodes_csv)
    flown = 0 if report_only else _fly(config, tasks, episodes_csv, address)
    rows = _summary_rows(tasks, agents, episodes_csv)
    table = write_summary(rows, out / "sweep.csv")
    minutes = (time.perf_counter() - started) / 60
    print(format_summary(table))
    print(f"{flown} episodes flown in {minutes:.1f} min; {len(rows)} in the summary")
    return SweepFlight(
        Path(out), config, config_path, table, rows, agents, None if report_only else minutes, compare_with
    )


def _load_sweep_config(config_path: Path, overrides: Mapping[str, int | str] | None) -> SweepConfig:
    """The config file with the command line's overrides, its counts and env kwargs checked."""
    config = load_config(config_path, SweepConfig)
    for name, value in (overrides or {}).items():
        setattr(config, name, value)
    if config.episodes < 1 or config.workers < 1:
        raise ValueError(f"--layouts and --workers must be >= 1, got {config.episodes} and {config.workers}")
    check_env_kwargs(config.env, str(config_path))
    return config


def _agents_with_policies(config: SweepConfig) -> list[str]:
    """The config's agents that can fly: a learned agent without its policy file (or ``<learned>@all`` without
    any shipped seed) is skipped, with a line saying where its policy was looked for."""
    files = {
        a: policy_file(a, directory=config.policy_folder())
        for a in config.agents
        if is_learned(a.removesuffix(ALL_SEEDS)) and not a.endswith(ALL_SEEDS)
    }
    missing = {a: path for a, path in files.items() if not path.exists()}
    for agent in config.agents:
        if agent.endswith(ALL_SEEDS) and not seed_rotation(config, agent):
            missing[agent] = config.policy_folder() / agent.removesuffix(ALL_SEEDS) / "seed_<k>.zip"
    for skipped, path in sorted(missing.items()):
        print(f"skipping {skipped}: no policy at {path}")
    return [a for a in config.agents if a not in missing]


def _check_flags(
    config: SweepConfig,
    config_path: Path,
    refly: list[str],
    compare_with: Path | None,
    report_only: bool,
    overwrite: bool,
) -> None:
    """Refuse, before any file is touched, flags that name unknown agents or files or that contradict each
    other."""
    for agent in refly:
        if agent not in config.agents:
            raise ValueError(
                f"--refly: {agent!r} is not an agent of {config_path} ({', '.join(config.agents)})"
            )
    if compare_with is not None and not compare_with.is_file():
        raise FileNotFoundError(f"--compare-with: no episodes CSV at {compare_with}")
    if refly and report_only:
        raise ValueError(
            "--refly deletes episodes to fly them again; it cannot be combined with --report-only"
        )
    if overwrite and report_only:
        raise ValueError("--overwrite starts a new episodes CSV; it cannot be combined with --report-only")


def _prepare_episodes_csv(out: Path, overwrite: bool) -> Path:
    """The episodes CSV in ``out`` (created if need be), moved aside first under ``--overwrite``."""
    check_writable_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    episodes_csv = out / "sweep_episodes.csv"
    if overwrite:
        moved = start_new_file(episodes_csv)
        if moved is not None:
            print(f"--overwrite: moved {episodes_csv} to {moved}")
    return episodes_csv


def _delete_refly_episodes(
    config: SweepConfig, tasks: list[EpisodeTask], refly: list[str], episodes_csv: Path
) -> None:
    """Delete the episodes of the ``--refly`` agents (every training seed of a ``<learned>@all``)."""
    runs = [run for agent in refly for run in seed_rotation(config, agent)]
    # Refuse before deleting anything what the run itself would refuse (a CSV from before identities,
    # other agents' episodes of other settings), so --refly never deletes episodes and then stops.
    pending_tasks([t for t in tasks if t.agent not in runs], episodes_csv, SWEEP_REMEDY)
    print(f"--refly: deleted {drop_agents(episodes_csv, runs)} episodes of {', '.join(refly)}")


def _fly(config: SweepConfig, tasks: list[EpisodeTask], episodes_csv: Path, address: str | None) -> int:
    """Fly the tasks not yet in the episodes CSV; the number flown."""
    return execute(
        tasks,
        episodes_csv,
        backend=config.backend,
        workers=config.workers,
        address=address,
        description="sweep",
        remedy=SWEEP_REMEDY,
    )


def _summary_rows(tasks: list[EpisodeTask], agents: list[str], episodes_csv: Path) -> list[PooledRow]:
    """The sweep's episodes in the CSV, each ``<learned>@all`` agent's seeds pooled."""
    episodes = read_episodes(episodes_csv)
    rows = pool_seeds(rows_of(tasks, episodes.rows), agents)
    if episodes.skipped:
        print(f"skipped {episodes.skipped} torn or corrupt rows of {episodes_csv}")
    return rows
