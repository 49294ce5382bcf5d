"""The committed data ``benchmark.md``, ``flow_gap.md`` and the generated blocks of the README and the thesis
discussion are written from, read and summarised once (what the study chose is :mod:`agents.common.study_choices`).

Everything comes from files under ``results/``: the leaderboard's and the sweep's episodes, the training seeds'
rates, the ablations on validation layouts, the diagnostic flights on true depths, the shipped policies' training
records and configs and the suite's top groups. Nothing is flown.
"""

from __future__ import annotations

import csv
import functools
import json
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypedDict

import numpy as np
import yaml

from agents.analysis.episode_record import EpisodeRow, PooledRow, is_flow_agent
from agents.analysis.over_seeds import LAYOUT_BLOCK, episode_outcomes
from agents.analysis.paired import Comparison, compare
from agents.analysis.records import read_records
from agents.analysis.statistics import failure, runs_failure
from agents.analysis.tolerance_rows import ToleranceRow
from agents.evaluation.leaderboard import LeaderboardRow, summarise_runs
from agents.evaluation.suite import SUITE_RESULTS_FOLDERS, TierTopGroup, suite_top_groups
from agents.evaluation.sweep import pool_every_seed
from agents.policies.base import (
    AGENT_NAMES,
    LEARNED_AGENTS,
    PRIVILEGED_AGENTS,
    REACTIVE_AGENTS,
    split_agent_name,
)
from agents.studies.error_analysis import baseline_of_flown_runs, tolerance_table
from flownav_env.tiers import SUITE_VERSION

# Each input, relative to results/, and the command that writes it (for the error naming a missing one).
INPUTS = {
    "leaderboard_episodes.csv": "flownav leaderboard --out results",
    "training_seeds.csv": "flownav leaderboard --out results",
    "sweep_episodes.csv": "flownav sweep --config configs/sweep.yaml --out results",
    "diagnostics/reactive_oracle_episodes.csv": "flownav evaluate --env obs_source=oracle (diagnostics/README.md)",
    "suite_episodes.csv": "flownav suite --out results",
}
# The ablations on validation layouts (flownav ablation): the clean folder and the two robustness conditions.
ABLATION_CONDITIONS = {"clean": "", "density": "density_0.18", "speed": "speed_1.5"}


@dataclass(frozen=True)
class Rate:
    """A failure rate with its 95 % interval and the episodes (and runs) it is over."""

    rate: float
    low: float
    high: float
    episodes: int
    runs: int = 1


class SeedRow(TypedDict):
    """One training run's rates as ``training_seeds.csv`` holds them (its training seed is "" for a reactive
    agent; its numbers read as floats)."""

    agent: str
    train_seed: str
    episodes: float
    success_rate: float
    failure_rate: float
    collision_rate: float
    out_of_bounds_rate: float


@dataclass(frozen=True)
class Training:
    """A learned agent's shipped training seeds: minutes per seed (both stages where it started from another's
    weights), the cores they trained on, and its config (of the last stage)."""

    minutes: list[float]
    cores: list[int]
    config: dict[str, Any]
    init_config: dict[str, Any] | None = None


@dataclass(frozen=True)
class BenchmarkData:
    """The summaries every report section draws on (see :func:`load_benchmark_data`)."""

    leaderboard: list[LeaderboardRow]
    layouts: list[int]
    leaderboard_episodes: int
    code_versions: dict[str, list[str]]
    seed_rows: list[SeedRow]
    sweep_rows: list[PooledRow]
    tolerance: list[ToleranceRow]
    cells: dict[tuple[str, str, float], Rate]
    validation: dict[str, dict[str, Rate]]
    oracle_reactive: dict[str, Rate]
    training: dict[str, Training]
    block: int = LAYOUT_BLOCK
    # Per agent (base name), its failures on the leading table's layouts, (runs, layouts): what two agents are
    # compared by (agents.analysis.paired).
    failures: dict[str, np.ndarray] = field(default_factory=dict)
    # Per sweep agent (its sweep name), its clean failure on the leading table's layouts over the training runs
    # the sweep flew: what a sweep cell's rise is measured from.
    sweep_clean: dict[str, Rate] = field(default_factory=dict)
    # Per suite tier: its best ranked agent, that agent's failure and the tier's top group (suite.md's ranking).
    suite_top: list[TierTopGroup] = field(default_factory=list)

    def best_agents(self) -> tuple[LeaderboardRow, LeaderboardRow]:
        """The leaderboard rows of the reactive agent (straight aside) and the learned flow agent with the lowest
        clean failure rate; a privileged agent (it reads what the sensor does not give) is a reference, never
        among them."""
        reactive = [r for r in self.leaderboard if r["agent"] in REACTIVE_AGENTS and r["agent"] != "straight"]
        learned = [
            r
            for r in self.leaderboard
            if r["agent"] in LEARNED_AGENTS and is_flow_agent(r) and r["agent"] not in PRIVILEGED_AGENTS
        ]
        return min(reactive, key=lambda r: r["failure_rate"]), min(learned, key=lambda r: r["failure_rate"])

    def row(self, agent: str) -> LeaderboardRow:
        """The leaderboard row of ``agent`` (a base name)."""
        return next(r for r in self.leaderboard if r["agent"] == agent)

    def compare(self, agent: str, reference: str) -> Comparison:
        """``agent`` against ``reference`` (base names) on the leading table's layouts, paired by layout with
        each one's training runs resampled: failure(agent) − failure(reference)."""
        return compare(agent, self.failures[agent], reference, self.failures[reference])

    def sweep_name(self, agent: str) -> str:
        """The sweep's name for a base agent name: itself, or its pooled ``<agent>@all``."""
        return agent if any(key[0] == agent for key in self.cells) else f"{agent}@all"

    def cell(self, agent: str, factor: str, level: float) -> Rate:
        """The sweep cell of ``agent`` (base name or pooled) at ``factor`` = ``level``."""
        return self.cells[(self.sweep_name(agent), factor, float(level))]

    def tolerance_row(self, agent: str, factor: str, side: str = "above") -> ToleranceRow | None:
        """The tolerance row of ``agent`` (base name or pooled) for ``factor`` on ``side``; None if not flown."""
        name = self.sweep_name(agent)
        wanted = (name, factor, side)
        return next((r for r in self.tolerance if (r["agent"], r["factor"], r["side"]) == wanted), None)


def require(path: Path) -> Path:
    """``path`` if it is a file; else a one-line FileNotFoundError naming it and what writes it."""
    if not path.is_file():
        writer = next((command for name, command in INPUTS.items() if path.as_posix().endswith(name)), None)
        hint = f" (written by `{writer}`)" if writer else ""
        raise FileNotFoundError(f"benchmark input not found: {path}{hint}")
    return path


def _rate(rows: Sequence[EpisodeRow]) -> Rate:
    """Failure over ``rows``: Wilson for one run, over runs and layouts for pooled ones."""
    return Rate(*failure(rows))


def _rates_per_agent(rows: Sequence[EpisodeRow]) -> dict[str, Rate]:
    return {
        agent: _rate([r for r in rows if r["agent"] == agent]) for agent in sorted({r["agent"] for r in rows})
    }


class _LeaderboardSummary(TypedDict):
    """The leaderboard's part of :class:`BenchmarkData` (its fields of the same names)."""

    leaderboard: list[LeaderboardRow]
    layouts: list[int]
    leaderboard_episodes: int
    code_versions: dict[str, list[str]]
    failures: dict[str, np.ndarray]


class _SweepSummary(TypedDict):
    """The sweep's part of :class:`BenchmarkData` (its fields of the same names)."""

    sweep_rows: list[PooledRow]
    tolerance: list[ToleranceRow]
    cells: dict[tuple[str, str, float], Rate]
    sweep_clean: dict[str, Rate]


def _leaderboard(results: Path) -> _LeaderboardSummary:
    rows = read_records(require(results / "leaderboard_episodes.csv"))
    runs: dict[str, list[str]] = {}
    versions: dict[str, set[str]] = {}
    for name in sorted({r["agent"] for r in rows}):
        runs.setdefault(split_agent_name(name)[0], []).append(name)
    for r in rows:
        versions.setdefault(split_agent_name(r["agent"])[0], set()).add(str(r["code_version"]))
    runs = {agent: runs[agent] for agent in AGENT_NAMES if agent in runs}
    layouts = sorted({int(r["seed"]) for r in rows})
    return {
        "leaderboard": summarise_runs(rows, runs, layouts),
        "layouts": layouts,
        "leaderboard_episodes": len(rows),
        "code_versions": {agent: sorted(versions[agent]) for agent in runs},
        "failures": {
            agent: episode_outcomes(rows, names, layouts, "failure") for agent, names in runs.items()
        },
    }


def _seed_rows(results: Path) -> list[SeedRow]:
    with require(results / "training_seeds.csv").open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    return [
        SeedRow(
            agent=r["agent"],
            train_seed=r["train_seed"],
            episodes=float(r["episodes"]),
            success_rate=float(r["success_rate"]),
            failure_rate=float(r["failure_rate"]),
            collision_rate=float(r["collision_rate"]),
            out_of_bounds_rate=float(r["out_of_bounds_rate"]),
        )
        for r in rows
    ]


def _sweep(results: Path) -> _SweepSummary:
    flown = read_records(require(results / "sweep_episodes.csv"))
    rows = pool_every_seed(flown)
    cells: dict[tuple[str, str, float], list[PooledRow]] = {}
    for r in rows:
        cells.setdefault((r["agent"], r["factor"], float(r["level"])), []).append(r)
    baseline = pool_every_seed(
        baseline_of_flown_runs(read_records(results / "leaderboard_episodes.csv"), flown)
    )
    clean = [r for r in baseline if r["factor"] == "clean"]
    return {
        "sweep_rows": rows,
        "tolerance": tolerance_table(rows, baseline),
        "cells": {key: _rate(members) for key, members in cells.items()},
        "sweep_clean": _rates_per_agent(clean),
    }


def seed_failures(folder: Path) -> np.ndarray | None:
    """Failures (seeds, layouts) of one ablation config's runs, one ``seed_<k>.csv`` each, layouts in seed order;
    None where none has flown or a seed has not flown the same layouts as the others."""
    files = sorted(folder.glob("seed_*.csv"))
    flown = [{int(r["seed"]): not bool(r["success"]) for r in read_records(file)} for file in files]
    if not flown or any(set(runs) != set(flown[0]) for runs in flown):
        return None
    return np.array([[runs[seed] for seed in sorted(flown[0])] for runs in flown], float)


def _config_rate(folder: Path) -> Rate:
    """Failure of a config's ablation runs (:func:`~agents.studies.error_analysis.runs_failure`).

    Raises:
        ValueError: runs that flew different layouts.
    """
    failures = seed_failures(folder)
    if failures is None:
        raise ValueError(f"{folder}: its runs have not all flown the same layouts")
    return Rate(*runs_failure(1.0 - failures), failures.size, len(failures))


def _validation(results: Path) -> dict[str, dict[str, Rate]]:
    """Failure rates on validation layouts per ablation condition: each config over its seeds, each reactive
    reference agent."""
    rates: dict[str, dict[str, Rate]] = {}
    for condition, folder in ABLATION_CONDITIONS.items():
        base = results / "ablation" / folder
        if not base.is_dir():
            raise FileNotFoundError(f"benchmark input not found: {base} (written by `flownav ablation`)")
        configs = sorted(p for p in base.iterdir() if p.is_dir() and any(p.glob("seed_*.csv")))
        found = {config.name: _config_rate(config) for config in configs}
        for file in sorted((base / "reference").glob("*.csv")):
            found[file.stem] = _rate(read_records(file))
        rates[condition] = found
    return rates


def _training(results: Path, agents: Sequence[str]) -> dict[str, Training]:
    """Each learned agent's training records (``policies/<agent>/seed_<k>.json``) and config (``.yaml``)."""
    found = {}
    for agent in agents:
        records = sorted((results / "policies" / agent).glob("seed_*.json"))
        if not records:
            raise FileNotFoundError(
                f"benchmark input not found: {results / 'policies' / agent}/seed_<k>.json (flownav train --ship)"
            )
        minutes, cores = [], set()
        for file in records:
            record = json.loads(file.read_text())
            minutes.append(float(record.get("total_wall_minutes_with_init", record["total_wall_minutes"])))
            cores |= {int(s["cores"]) for s in record.get("sessions", []) if "cores" in s}
        config = yaml.safe_load(require(records[0].with_suffix(".yaml")).read_text())
        init = None
        if config.get("init_from"):
            source = Path(str(config["init_from"]).format(seed=0))
            init = yaml.safe_load(
                require(results / "policies" / source.parent.name / f"{source.stem}.yaml").read_text()
            )
        found[agent] = Training(minutes, sorted(cores), config, init)
    return found


def _fingerprint(results: Path) -> tuple[tuple[str, int, int], ...]:
    """Name, size and modification time of every input file: a summary is reused only while none changed."""
    patterns = [*INPUTS, "ablation/**/*.csv", "policies/*/seed_*.json", "policies/*/seed_*.yaml"]
    files = sorted({file for pattern in patterns for file in results.glob(pattern) if file.is_file()})
    return tuple((str(file), file.stat().st_size, file.stat().st_mtime_ns) for file in files)


def load_benchmark_data(results_dir: Path) -> BenchmarkData:
    """Read and summarise every input under ``results_dir``, a folder with the layout of ``results/``.

    Raises:
        FileNotFoundError: a missing input, named in one line.
        ValueError: runs of an ablation that flew different layouts.
    """
    results = Path(results_dir).resolve()
    for name in INPUTS:
        require(results / name)
    return _summarise(results, _fingerprint(results))


# One summary kept: the bootstrap intervals take a while, and every report of one regeneration reads
# the same files; the fingerprint in the key makes a changed file read anew.
@functools.lru_cache(maxsize=1)
def _summarise(results: Path, fingerprint: tuple[tuple[str, int, int], ...]) -> BenchmarkData:
    del fingerprint  # part of the cache key only
    leaderboard = _leaderboard(results)
    learned = [r["agent"] for r in leaderboard["leaderboard"] if r["agent"] in LEARNED_AGENTS]
    oracle = read_records(require(results / "diagnostics/reactive_oracle_episodes.csv"))
    return BenchmarkData(
        **leaderboard,
        seed_rows=_seed_rows(results),
        **_sweep(results),
        validation=_validation(results),
        oracle_reactive=_rates_per_agent(oracle),
        training=_training(results, learned),
        suite_top=suite_top_groups(results / SUITE_RESULTS_FOLDERS[SUITE_VERSION], version=SUITE_VERSION),
    )


def commit_of(code_version: str) -> str:
    """``commit `abc1234` with uncommitted changes in ...`` → ```abc1234` with uncommitted changes``."""
    match = re.search(r"commit `(\w+)`", code_version)
    name = f"`{match.group(1)}`" if match else code_version
    return f"{name} with uncommitted changes" if "uncommitted" in code_version else name
