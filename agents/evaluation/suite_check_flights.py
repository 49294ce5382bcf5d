"""Suite v2's check flights (``results/suite_v2_calibration/``) read and summarised: each privileged reference's
feasibility per tier, and the noisy tiers at other readings of the velocity specification paired by layout with
the frozen one. Its calibration page words these values (:mod:`agents.pages.calibration_page`).

This module reads episodes, nothing else: it imports only the analysis and the bottom layer (an import-linter
contract in ``pyproject.toml`` and ``tests/agents/pages/test_calibration_page.py`` keep it so: no MuJoCo,
Gymnasium or env). The physics the page states, the frozen tiers and the sensor's velocity readings, is code, not
data: its caller reads it from the env package and hands it in as :class:`FrozenPhysics`
(:func:`agents.evaluation.suite_checks.frozen_physics`).

Nothing here chooses a setting: a tier passes its check when each reference fails at most
:data:`FEASIBLE_FAILURE` of the checked layouts.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypedDict

import numpy as np

from agents.analysis.episode_record import EpisodeRow
from agents.analysis.paired import Comparison, compare
from agents.analysis.records import read_records
from agents.analysis.statistics import wilson_interval

# A tier is feasible when each privileged reference fails at most this share of the checked layouts.
FEASIBLE_FAILURE = 0.02
# The references checked, in the order the page lists them; a missing one is listed as not yet flown.
CHECK_AGENTS = ("planner", "planner_camera")
SENSITIVITY_DIR = "sensitivity"
# sensitivity/<agent>_<env id>_<reading>_tau<τ>.csv: agent names and readings hold underscores, ids do not.
SENSITIVITY_NAME = re.compile(
    r"^(?P<agent>.+)_(?P<env_id>FlowNav[A-Za-z]*-v\d+)_(?P<reading>[a-z0-9_]+)_tau(?P<tau>[0-9.]+)$"
)


@dataclass(frozen=True)
class TierFacts:
    """One frozen tier as the page states it: its name, registered id, why it is so, and the settings it fixes."""

    name: str
    env_id: str
    why: str
    settings: Mapping[str, Any]


@dataclass(frozen=True)
class FrozenPhysics:
    """What suite v2 froze in code, as the page states it: the tiers (in the suite's order), the radii behind the
    hard tier's mean free path, and the GNSS velocity's readings (``velocity_readings``: reading → its meaning
    and per-axis σ in m/s), the one the flight stack uses and the error's correlation times."""

    tiers: tuple[TierFacts, ...]
    capsule_radius_m: float
    hull_radius_m: float
    hard_free_path_s: float
    velocity_accuracy_m_s: float
    velocity_readings: Mapping[str, tuple[str, float]]
    flight_stack_reading: str
    velocity_correlation_s: float
    velocity_correlation_readings_s: tuple[float, ...]

    def tier(self, name: str) -> TierFacts:
        """The tier called ``name``.

        Raises:
            ValueError: no tier of that name.
        """
        for facts in self.tiers:
            if facts.name == name:
                return facts
        raise ValueError(f"no tier {name!r}; the tiers are {', '.join(t.name for t in self.tiers)}")


def sensitivity_file(agent: str, env_id: str, reading: str, tau: float) -> str:
    """The file name of ``agent``'s flight of ``env_id`` at velocity ``reading`` and correlation time ``tau``."""
    return f"{agent}_{env_id}_{reading}_tau{tau:g}.csv"


class _CheckedPair(TypedDict):
    """A (tier, reference) pair the checks cover; ``layouts`` 0 until it is flown."""

    tier: str
    env_id: str
    agent: str
    layouts: int


class CheckRow(_CheckedPair, total=False):
    """A (tier, reference) check (:func:`check_rows`): a flown one has its first layout, its failure with a Wilson
    interval, its widest sideways excursion and whether it passes."""

    first_seed: int
    failure: float
    low: float
    high: float
    widest_m: float
    passes: bool


class SensitivityRow(TypedDict):
    """A noisy tier flown at another reading of the velocity specification, paired by layout with the frozen
    reading's flight of the same agent (:func:`sensitivity_rows`)."""

    agent: str
    env_id: str
    reading: str
    tau: float
    layouts: int
    frozen_failure: float
    failure: float
    comparison: Comparison


def _episodes(path: Path) -> list[EpisodeRow]:
    return [row for row in read_records(path) if row.get("seed") is not None]


def check_rows(folder: Path, tiers: Sequence[TierFacts]) -> list[CheckRow]:
    """Per (tier, reference) flown: layouts, failures with a Wilson interval, the widest sideways excursion, and
    whether it passes (:data:`FEASIBLE_FAILURE`)."""
    found: list[CheckRow] = []
    for spec in tiers:
        for agent in CHECK_AGENTS:
            path = Path(folder) / f"{agent}_{spec.env_id}.csv"
            if not path.is_file():
                found.append({"tier": spec.name, "env_id": spec.env_id, "agent": agent, "layouts": 0})
                continue
            rows = _episodes(path)
            failed = sum(1 for row in rows if not row["success"])
            low, high = wilson_interval(failed, len(rows))
            found.append(
                {
                    "tier": spec.name,
                    "env_id": spec.env_id,
                    "agent": agent,
                    "layouts": len(rows),
                    "first_seed": min(int(row["seed"]) for row in rows),
                    "failure": failed / len(rows),
                    "low": low,
                    "high": high,
                    "widest_m": max(float(row.get("max_abs_lateral_m") or 0.0) for row in rows),
                    "passes": failed / len(rows) <= FEASIBLE_FAILURE,
                }
            )
    return found


def sensitivity_rows(folder: Path, physics: FrozenPhysics) -> list[SensitivityRow]:
    """The noisy tiers at other readings of the velocity specification, each paired by layout with the frozen
    reading's flight of the same agent (``sensitivity/<agent>_<env id>_<reading>_<tau>.csv``)."""
    found: list[SensitivityRow] = []
    frozen = (physics.flight_stack_reading, physics.velocity_correlation_s)
    for path in sorted((Path(folder) / SENSITIVITY_DIR).glob("*.csv")):
        match = SENSITIVITY_NAME.match(path.stem)
        if match is None:
            continue
        agent, env_id, reading, tau = match.group("agent", "env_id", "reading", "tau")
        if (reading, float(tau)) == frozen:
            continue
        base_path = path.with_name(sensitivity_file(agent, env_id, *frozen))
        if not base_path.is_file():
            continue
        other = {int(r["seed"]): float(not r["success"]) for r in _episodes(path)}
        base = {int(r["seed"]): float(not r["success"]) for r in _episodes(base_path)}
        seeds = sorted(set(other) & set(base))
        if not seeds:
            continue
        mine = np.array([[other[s] for s in seeds]])
        reference = np.array([[base[s] for s in seeds]])
        found.append(
            {
                "agent": agent,
                "env_id": env_id,
                "reading": physics.velocity_readings[reading][0],
                "tau": float(tau),
                "layouts": len(seeds),
                "frozen_failure": float(reference.mean()),
                "failure": float(mine.mean()),
                "comparison": compare("other", mine, "frozen", reference),
            }
        )
    return found


def passing(checks: Sequence[CheckRow]) -> bool:
    """Whether every reference flown passes on every tier it flew."""
    return all(row.get("passes") for row in checks if row["layouts"])
