"""The committed data ``benchmark.md`` and the README's results are written from, read and summarised once.

Everything comes from files under ``results/``: the leaderboard's and the sweep's episodes, the training seeds'
rates, the ablations on validation layouts, the diagnostic flights on true depths, the shipped policies' training
records and configs, and the thesis replication's measured motion. Nothing is flown.
"""

from __future__ import annotations

import csv
import json
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from agents.evaluation.leaderboard import improvements, summarise_runs
from agents.evaluation.over_seeds import LAYOUT_BLOCK, episode_outcomes
from agents.evaluation.paired import Comparison, compare
from agents.evaluation.records import read_records
from agents.evaluation.statistics import failure_interval, runs_and_layouts_interval, wilson_interval
from agents.evaluation.suite import suite_top_groups
from agents.evaluation.sweep import pool_every_seed
from agents.policies.base import AGENT_NAMES, LEARNED_AGENTS, split_agent_name
from agents.studies.error_analysis import cell_quality, fit_dose_response, is_flow_agent, tolerance_table

# Each input, relative to results/, and the command that writes it (for the error naming a missing one).
SUITE_EPISODES = "suite_episodes.csv"
INPUTS = {
    "leaderboard_episodes.csv": "flownav leaderboard --out results",
    "training_seeds.csv": "flownav leaderboard --out results",
    "sweep_episodes.csv": "flownav sweep --config configs/sweep.yaml --out results",
    "diagnostics/reactive_oracle_episodes.csv": "flownav evaluate --env obs_source=oracle (diagnostics/README.md)",
    "thesis/three_capsule.json": "flownav replicate --out results/thesis",
    SUITE_EPISODES: "flownav suite --out results",
}
# The ablations on validation layouts (flownav ablation): the clean folder and the two robustness conditions.
ABLATION_DIR = "ablation"
ABLATION_CONDITIONS = {"clean": "", "density": "density_0.18", "speed": "speed_1.5"}
REFERENCE_DIR = "reference"


@dataclass(frozen=True)
class Rate:
    """A failure rate with its 95 % interval and the episodes (and runs) it is over."""

    rate: float
    low: float
    high: float
    episodes: int
    runs: int = 1


@dataclass(frozen=True)
class Training:
    """A learned agent's shipped training seeds: minutes per seed (both stages where it started from another's
    weights), the cores they trained on, and its config (of the last stage)."""

    minutes: list[float]
    cores: list[int]
    config: dict[str, Any]
    init_config: dict[str, Any] | None = None


@dataclass
class BenchmarkData:
    """The summaries every report section draws on (see :func:`load_benchmark_data`)."""

    leaderboard: list[dict[str, Any]]
    gains: list[dict[str, Any]]
    layouts: list[int]
    leaderboard_episodes: int
    code_versions: dict[str, list[str]]
    seed_rows: list[dict[str, Any]]
    sweep_rows: list[dict[str, Any]]
    sweep_seeds: dict[str, int]
    sweep_code_versions: list[tuple[str, int, list[str]]]
    tolerance: list[dict[str, Any]]
    cells: dict[tuple[str, str, float], Rate]
    fits: dict[str, dict[str, Any]]
    fit_errors: dict[str, str]
    validation: dict[str, dict[str, Rate]]
    oracle_reactive: dict[str, Rate]
    training: dict[str, Training]
    thesis_motion: dict[str, Any]
    block: int = LAYOUT_BLOCK
    # Per agent (base name), its failures on the leading table's layouts, (runs, layouts): what two agents are
    # compared by (agents.evaluation.paired).
    failures: dict[str, np.ndarray] = field(default_factory=dict)
    # Per suite tier: its best ranked agent, that agent's failure and the tier's top group (suite.md's ranking).
    suite_top: list[dict[str, Any]] = field(default_factory=list)

    def row(self, agent: str) -> dict[str, Any]:
        """The leaderboard row of ``agent`` (a base name)."""
        return next(r for r in self.leaderboard if r["agent"] == agent)

    def compare(self, agent: str, reference: str) -> Comparison:
        """``agent`` against ``reference`` (base names) on the leading table's layouts, paired by layout with
        each one's training runs resampled: failure(agent) − failure(reference)."""
        return compare(agent, self.failures[agent], reference, self.failures[reference])

    def gain(self, learned: str, reactive: str) -> dict[str, Any]:
        """P(``learned`` > ``reactive``) with its interval."""
        return next(g for g in self.gains if g["learned"] == learned and g["reactive"] == reactive)

    def cell(self, agent: str, factor: str, level: float) -> Rate:
        """The sweep cell of ``agent`` (base name or pooled) at ``factor`` = ``level``."""
        return self.cells[(sweep_name(agent, self.cells), factor, float(level))]

    def tolerance_row(self, agent: str, factor: str, side: str) -> dict[str, Any] | None:
        name = sweep_name(agent, self.cells)
        return next(
            (r for r in self.tolerance if r["agent"] == name and r["factor"] == factor and r["side"] == side),
            None,
        )


def sweep_name(agent: str, cells: Mapping[tuple[str, str, float], Any]) -> str:
    """The sweep's name for a base agent name: itself, or its pooled ``<agent>@all``."""
    names = {key[0] for key in cells}
    return agent if agent in names else f"{agent}@all"


def require(path: Path) -> Path:
    """``path`` if it is a file; else a one-line FileNotFoundError naming it and what writes it."""
    if not path.is_file():
        writer = next((command for name, command in INPUTS.items() if path.as_posix().endswith(name)), None)
        hint = f" (written by `{writer}`)" if writer else ""
        raise FileNotFoundError(f"benchmark input not found: {path}{hint}")
    return path


def _rate(rows: Sequence[Mapping[str, Any]]) -> Rate:
    failures = sum(not bool(r["success"]) for r in rows)
    low, high = failure_interval(rows)
    return Rate(failures / len(rows), low, high, len(rows))


def _leaderboard(results: Path) -> dict[str, Any]:
    rows = read_records(require(results / "leaderboard_episodes.csv"))
    runs: dict[str, list[str]] = {}
    for name in sorted({r["agent"] for r in rows}):
        runs.setdefault(split_agent_name(name)[0], []).append(name)
    runs = {agent: runs[agent] for agent in AGENT_NAMES if agent in runs}
    layouts = sorted({int(r["seed"]) for r in rows})
    versions: dict[str, set[str]] = {}
    for r in rows:
        versions.setdefault(split_agent_name(r["agent"])[0], set()).add(str(r["code_version"]))
    return {
        "leaderboard": summarise_runs(rows, runs, layouts),
        "gains": improvements(rows, runs, layouts),
        "layouts": layouts,
        "leaderboard_episodes": len(rows),
        "code_versions": {agent: sorted(versions[agent]) for agent in runs},
        "failures": {
            agent: episode_outcomes(rows, names, layouts, "failure") for agent, names in runs.items()
        },
    }


def _seed_rows(results: Path) -> list[dict[str, Any]]:
    with require(results / "training_seeds.csv").open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    numeric = ("episodes", "success_rate", "failure_rate", "collision_rate", "out_of_bounds_rate")
    return [{**r, **{key: float(r[key]) for key in numeric}} for r in rows]


def _sweep(results: Path) -> dict[str, Any]:
    raw = read_records(require(results / "sweep_episodes.csv"))
    seeds: dict[str, set[int]] = {}
    versions: dict[str, tuple[int, set[str]]] = {}
    for r in raw:
        base, seed = split_agent_name(r["agent"])
        if seed is not None:
            seeds.setdefault(base, set()).add(seed)
        count, agents = versions.get(str(r["code_version"]), (0, set()))
        versions[str(r["code_version"])] = (count + 1, agents | {base})
    rows = pool_every_seed(raw)
    cells: dict[tuple[str, str, float], list[dict[str, Any]]] = {}
    for r in rows:
        cells.setdefault((r["agent"], r["factor"], float(r["level"])), []).append(r)
    quality = cell_quality(rows)
    fits, errors = {}, {}
    for agent in sorted({r["agent"] for r in rows if is_flow_agent(r)}):
        try:
            fits[agent] = fit_dose_response([r for r in rows if r["agent"] == agent], quality)
        except ValueError as reason:
            errors[agent] = str(reason)
    baseline = pool_every_seed(read_records(results / "leaderboard_episodes.csv"))
    return {
        "sweep_rows": rows,
        "sweep_seeds": {base: len(found) for base, found in seeds.items()},
        "sweep_code_versions": [(v, n, sorted(agents)) for v, (n, agents) in versions.items()],
        "tolerance": tolerance_table(rows, baseline),
        "cells": {key: _rate(members) for key, members in cells.items()},
        "fits": fits,
        "fit_errors": errors,
    }


def _run_outcomes(files: Sequence[Path]) -> np.ndarray:
    """Success per (run, layout) of ablation runs that flew the same layouts, one CSV per run."""
    flown = [{int(r["seed"]): bool(r["success"]) for r in read_records(file)} for file in files]
    layouts = sorted(set().union(*flown))
    for file, runs in zip(files, flown, strict=True):
        if set(runs) != set(layouts):
            raise ValueError(f"{file}: its run has not flown the same layouts as the others in its folder")
    return np.array([[runs[seed] for seed in layouts] for runs in flown], float)


def _validation(results: Path) -> dict[str, dict[str, Rate]]:
    """Failure rates on validation layouts per ablation condition: each config over its seeds (two-level
    bootstrap, as ``flownav ablation``), each reactive reference agent (Wilson)."""
    rates: dict[str, dict[str, Rate]] = {}
    for condition, folder in ABLATION_CONDITIONS.items():
        base = results / ABLATION_DIR / folder
        if not base.is_dir():
            raise FileNotFoundError(f"benchmark input not found: {base} (written by `flownav ablation`)")
        found: dict[str, Rate] = {}
        for config in sorted(p for p in base.iterdir() if p.is_dir() and any(p.glob("seed_*.csv"))):
            outcomes = _run_outcomes(sorted(config.glob("seed_*.csv")))
            if len(outcomes) > 1:
                low, high = runs_and_layouts_interval(outcomes)
            else:
                low, high = wilson_interval(int(outcomes.sum()), outcomes.size)
            found[config.name] = Rate(1 - outcomes.mean(), 1 - high, 1 - low, outcomes.size, len(outcomes))
        for file in sorted((base / REFERENCE_DIR).glob("*.csv")):
            rows = read_records(file)
            failures = sum(not bool(r["success"]) for r in rows)
            low, high = wilson_interval(failures, len(rows))
            found[file.stem] = Rate(failures / len(rows), low, high, len(rows))
        rates[condition] = found
    return rates


def _oracle_reactive(results: Path) -> dict[str, Rate]:
    rows = read_records(require(results / "diagnostics/reactive_oracle_episodes.csv"))
    rates = {}
    for agent in sorted({r["agent"] for r in rows}):
        mine = [r for r in rows if r["agent"] == agent]
        failures = sum(not bool(r["success"]) for r in mine)
        low, high = wilson_interval(failures, len(mine))
        rates[agent] = Rate(failures / len(mine), low, high, len(mine))
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
            init_yaml = results / "policies" / source.parent.name / f"{source.stem}.yaml"
            init = yaml.safe_load(require(init_yaml).read_text())
        found[agent] = Training(minutes, sorted(cores), config, init)
    return found


def _fingerprint(results: Path) -> tuple[Any, ...]:
    """Name, size and modification time of every input file, so a cached summary is used only while none
    changed."""
    patterns = [*INPUTS, f"{ABLATION_DIR}/**/*.csv", "policies/*/seed_*.json", "policies/*/seed_*.yaml"]
    files = sorted({file for pattern in patterns for file in results.glob(pattern) if file.is_file()})
    return tuple((str(file), file.stat().st_size, file.stat().st_mtime_ns) for file in files)


_CACHE: dict[tuple[str, tuple[Any, ...]], BenchmarkData] = {}


def load_benchmark_data(results_dir: Path) -> BenchmarkData:
    """Read and summarise every input of the benchmark report under ``results_dir`` (cached while the files are
    unchanged, since the probabilities of improvement take minutes).

    Args:
        results_dir: a folder with the layout of ``results/``.

    Returns:
        The summaries.

    Raises:
        FileNotFoundError: a missing input, named in one line.
        ValueError: runs of an ablation that flew different layouts.
    """
    results = Path(results_dir)
    for name in INPUTS:
        require(results / name)
    key = (str(results.resolve()), _fingerprint(results))
    if key not in _CACHE:
        leaderboard = _leaderboard(results)
        learned = [r["agent"] for r in leaderboard["leaderboard"] if r["agent"] in LEARNED_AGENTS]
        _CACHE.clear()
        _CACHE[key] = BenchmarkData(
            **leaderboard,
            seed_rows=_seed_rows(results),
            **_sweep(results),
            validation=_validation(results),
            oracle_reactive=_oracle_reactive(results),
            training=_training(results, learned),
            thesis_motion=json.loads((results / "thesis/three_capsule.json").read_text())["motion"],
            suite_top=suite_top_groups(results),
        )
    return _CACHE[key]


def commit_of(code_version: str) -> str:
    """``commit `abc1234` with uncommitted changes in ...`` → ```abc1234` with uncommitted changes``."""
    match = re.search(r"commit `(\w+)`", code_version)
    name = f"`{match.group(1)}`" if match else code_version
    return f"{name} with uncommitted changes" if "uncommitted" in code_version else name
