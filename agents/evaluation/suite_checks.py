"""Suite v2's calibration page: the tiers' physics and sensor as frozen in code, and the only flights made before
the freeze, the privileged references' feasibility checks on validation layouts (``results/suite_v2_calibration/``).

Nothing here chooses a setting: the tiers are fixed in :mod:`flownav_env.tiers` from stated physics, and a tier
passes its check when each reference fails at most :data:`FEASIBLE_FAILURE` of the checked layouts. The flights are
``flownav evaluate --agent AGENT --env-id ENV --episodes N --seed-start SUITE_V2_CHECK_SEED_START --out
results/suite_v2_calibration/AGENT_ENV.csv``; the noisy tier at other readings of the velocity specification
(the sensitivity table) lies in ``sensitivity/AGENT_ENV_READING_TAU.csv`` beside them.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from agents.analysis.episode_record import EpisodeRow
from agents.analysis.paired import compare
from agents.analysis.records import read_records
from agents.analysis.statistics import wilson_interval
from agents.common.folders import write_text_atomically
from agents.common.jinja_reports import render
from agents.common.seeds import SUITE_V2_CHECK_SEED_START, SUITE_V2_SENSOR_READING_SEED_START
from flownav_env import sensor_specs
from flownav_env.tiers import (
    CAPSULE_RADIUS_M,
    HARD_FREE_PATH_S,
    HULL_RADIUS_M,
    TIER_NAMES,
    tier,
)

CHECKED_VERSION = "2"
# A tier is feasible when each privileged reference fails at most this share of the checked layouts.
FEASIBLE_FAILURE = 0.02
# The references checked, in the order the page lists them; a missing one is listed as not yet flown.
CHECK_AGENTS = ("planner", "planner_camera")
SENSITIVITY_DIR = "sensitivity"
# sensitivity/<agent>_<env id>_<reading>_tau<τ>.csv: agent names and readings hold underscores, ids do not.
SENSITIVITY_NAME = re.compile(
    r"^(?P<agent>.+)_(?P<env_id>FlowNav[A-Za-z]*-v\d+)_(?P<reading>[a-z0-9_]+)_tau(?P<tau>[0-9.]+)$"
)


def sensitivity_file(agent: str, env_id: str, reading: str, tau: float) -> str:
    """The file name of ``agent``'s flight of ``env_id`` at velocity ``reading`` and correlation time ``tau``."""
    return f"{agent}_{env_id}_{reading}_tau{tau:g}.csv"


PAGE = "calibration.md"


def _episodes(path: Path) -> list[EpisodeRow]:
    return [row for row in read_records(path) if row.get("seed") is not None]


def check_rows(folder: Path) -> list[dict[str, Any]]:
    """Per (tier, reference) flown: layouts, failures with a Wilson interval, the widest sideways excursion, and
    whether it passes (:data:`FEASIBLE_FAILURE`)."""
    found = []
    for name in TIER_NAMES:
        spec = tier(name, CHECKED_VERSION)
        for agent in CHECK_AGENTS:
            path = Path(folder) / f"{agent}_{spec.env_id}.csv"
            if not path.is_file():
                found.append({"tier": name, "env_id": spec.env_id, "agent": agent, "layouts": 0})
                continue
            rows = _episodes(path)
            failed = sum(1 for row in rows if not row["success"])
            low, high = wilson_interval(failed, len(rows))
            found.append(
                {
                    "tier": name,
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


def sensitivity_rows(folder: Path) -> list[dict[str, Any]]:
    """The noisy tiers at other readings of the velocity specification, each paired by layout with the frozen
    reading's flight of the same agent (``sensitivity/<agent>_<env id>_<reading>_<tau>.csv``)."""
    found = []
    frozen = (sensor_specs.FLIGHT_STACK_READING, sensor_specs.VELOCITY_CORRELATION_S)
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
                "reading": sensor_specs.VELOCITY_READINGS[reading][0],
                "tau": float(tau),
                "layouts": len(seeds),
                "frozen_failure": float(reference.mean()),
                "failure": float(mine.mean()),
                "comparison": compare("other", mine, "frozen", reference),
            }
        )
    return found


def check_values(folder: Path, command: str) -> dict[str, Any]:
    """Every value the calibration page words."""
    checks = check_rows(folder)
    tiers = []
    for name in TIER_NAMES:
        spec = tier(name, CHECKED_VERSION)
        tiers.append({"name": name, "env_id": spec.env_id, "why": spec.why, "settings": dict(spec.settings)})
    hard = tier("hard", CHECKED_VERSION).settings
    readings = sensor_specs.VELOCITY_READINGS
    return {
        "command": command,
        "tiers": tiers,
        "checks": checks,
        "all_pass": passing(checks),
        "all_flown": all(row["layouts"] for row in checks),
        "sensitivity": sensitivity_rows(folder),
        "feasible_failure": FEASIBLE_FAILURE,
        "check_seed": SUITE_V2_CHECK_SEED_START,
        "sensitivity_seed": SUITE_V2_SENSOR_READING_SEED_START,
        "capsule_radius": CAPSULE_RADIUS_M,
        "hull_radius": HULL_RADIUS_M,
        "free_path_s": HARD_FREE_PATH_S,
        "hard_speed": hard["forward_speed"],
        "hard_density": hard["obstacle_density"],
        "free_path_m": 1.0 / (hard["obstacle_density"] * 2 * (CAPSULE_RADIUS_M + HULL_RADIUS_M)),
        "field_width": hard["field_width"],
        "lateral_bound": hard["lateral_bound"],
        "reading": readings[sensor_specs.FLIGHT_STACK_READING][0],
        "velocity_sigma": readings[sensor_specs.FLIGHT_STACK_READING][1],
        "readings": [
            {"name": key, "meaning": meaning, "sigma": sigma} for key, (meaning, sigma) in readings.items()
        ],
        "tau": sensor_specs.VELOCITY_CORRELATION_S,
        "taus": list(sensor_specs.VELOCITY_CORRELATION_READINGS_S),
        "accuracy": sensor_specs.VELOCITY_ACCURACY_M_S,
    }


def write_checks(folder: Path, command: str) -> Sequence[str]:
    """Write ``<folder>/calibration.md`` from the checks flown into ``folder``; returns its lines."""
    text = render("agents.evaluation", "suite_checks.md.j2", check_values(Path(folder), command))
    write_text_atomically(Path(folder) / PAGE, text)
    return text.splitlines()


def passing(checks: Sequence[Mapping[str, object]]) -> bool:
    """Whether every reference flown passes on every tier it flew."""
    return all(row["passes"] for row in checks if row["layouts"])
