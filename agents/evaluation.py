"""One evaluation path for every agent: episodes, their records, the CSV they append to, and the statistics.

Seeds: training uses env seeds below :data:`EVAL_SEED_START`; evaluation and sweeps draw from
``EVAL_SEED_START`` on, so no evaluated layout was ever seen in training.
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from agents.policies import Agent

EVAL_SEED_START = 1_000_000
TRAIN_EVAL_SEED_START = 500_000  # held-out seeds of the training-time eval callback


@dataclass
class EpisodeRecord:
    """What one episode came to; one CSV row."""

    agent: str
    factor: str
    level: float
    seed: int
    collision: bool
    success: bool
    out_of_bounds: bool
    truncated: bool
    progress_m: float
    time_s: float
    steps: int
    min_clearance_m: float
    path_length_m: float
    mean_points_valid: float
    median_depth_error: float
    episode_return: float


def run_episode(
    env: Any, agent: Agent, seed: int, *, label: str = "", factor: str = "clean", level: float = 0.0
) -> EpisodeRecord:
    """Fly one episode of ``env`` with ``agent`` from ``reset(seed=seed)`` to termination or truncation."""
    observation, info = env.reset(seed=seed)
    position = np.array([0.0, 0.0, 0.0])
    path_length, total_return, steps = 0.0, 0.0, 0
    valid_points, depth_errors = [], []
    terminated = truncated = False
    while not (terminated or truncated):
        action, _ = agent.predict(observation, deterministic=True)
        observation, reward, terminated, truncated, info = env.step(action)
        steps += 1
        total_return += reward
        new_position = info["position"]
        if steps > 1:
            path_length += float(np.linalg.norm(new_position - position))
        position = new_position
        valid_points.append(info["points_valid"])
        if "depth_error_median" in info:
            depth_errors.append(info["depth_error_median"])
    frame_rate = env.unwrapped.frame_rate
    return EpisodeRecord(
        agent=label,
        factor=factor,
        level=float(level),
        seed=int(seed),
        collision=bool(info["collision"]),
        success=bool(info["success"]),
        out_of_bounds=bool(info.get("out_of_bounds", False)),
        truncated=bool(truncated and not terminated),
        progress_m=float(info["progress"]),
        time_s=steps / frame_rate,
        steps=steps,
        min_clearance_m=float(info["min_clearance"]),
        path_length_m=path_length,
        mean_points_valid=float(np.mean(valid_points)) if valid_points else 0.0,
        median_depth_error=float(np.median(depth_errors)) if depth_errors else math.nan,
        episode_return=float(total_return),
    )


CSV_FIELDS = [f.name for f in fields(EpisodeRecord)]


def append_record(path: Path, record: EpisodeRecord) -> None:
    """Append one row and flush it to disk, so an interrupted run loses at most the episode in flight."""
    path.parent.mkdir(parents=True, exist_ok=True)
    new_file = not path.exists() or path.stat().st_size == 0
    torn = False
    if not new_file:
        with path.open("rb") as existing:
            existing.seek(-1, os.SEEK_END)
            torn = existing.read(1) != b"\n"
    with path.open("a", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=CSV_FIELDS)
        if new_file:
            writer.writeheader()
        if torn:
            handle.write("\n")  # end a row cut off by an interruption; reading skips it
        writer.writerow(asdict(record))
        handle.flush()
        os.fsync(handle.fileno())


def read_records(path: Path) -> list[dict[str, Any]]:
    """Rows of an episodes CSV with typed values; a missing file gives no rows. A torn last line is skipped."""
    if not path.exists():
        return []
    types = {f.name: f.type for f in fields(EpisodeRecord)}
    rows = []
    with path.open(newline="") as handle:
        for raw in csv.DictReader(handle):
            if None in raw.values() or len(raw) != len(CSV_FIELDS):
                continue
            row: dict[str, Any] = {}
            for key, text in raw.items():
                kind = types[key]
                if kind in ("bool", bool):
                    row[key] = text == "True"
                elif kind in ("int", int):
                    row[key] = int(text)
                elif kind in ("float", float):
                    row[key] = float(text)
                else:
                    row[key] = text
            rows.append(row)
    return rows


def drop_agents(path: Path, agents: Iterable[str]) -> int:
    """Delete every row of ``agents`` from an episodes CSV, so a resumed run flies them again (after a policy
    is retrained, its old episodes no longer describe it). Other rows are kept byte for byte; the file is
    replaced atomically, so an interruption leaves either the old or the new file. Returns the rows deleted."""
    if not path.exists():
        return 0
    dropped = set(agents)
    with path.open(newline="") as handle:
        lines = handle.read().splitlines(keepends=True)
    if not lines:
        return 0
    kept = [lines[0]] + [line for line in lines[1:] if line.split(",", 1)[0] not in dropped]
    temporary = path.with_name(path.name + ".tmp")
    temporary.write_text("".join(kept))
    os.replace(temporary, path)
    return len(lines) - len(kept)


def completed_keys(rows: Iterable[Mapping[str, Any]]) -> set[tuple[str, str, float, int]]:
    """(agent, factor, level, seed) of finished episodes: what a resumed run skips."""
    return {(r["agent"], r["factor"], float(r["level"]), int(r["seed"])) for r in rows}


def wilson_interval(successes: int, trials: int, z: float = 1.959964) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion (95 % by default); (0, 1) for no trials."""
    if trials <= 0:
        return 0.0, 1.0
    p = successes / trials
    denominator = 1 + z**2 / trials
    centre = (p + z**2 / (2 * trials)) / denominator
    half = z * math.sqrt(p * (1 - p) / trials + z**2 / (4 * trials**2)) / denominator
    return max(0.0, centre - half), min(1.0, centre + half)


def summarise(rows: Iterable[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Per (agent, factor, level): episodes, collisions, collision rate with its Wilson 95 % interval,
    success rate with its interval, and medians of progress and clearance."""
    groups: dict[tuple[str, str, float], list[Mapping[str, Any]]] = {}
    for row in rows:
        groups.setdefault((row["agent"], row["factor"], float(row["level"])), []).append(row)
    table = []
    for (agent, factor, level), members in sorted(groups.items()):
        n = len(members)
        collisions = sum(bool(m["collision"]) for m in members)
        successes = sum(bool(m["success"]) for m in members)
        low, high = wilson_interval(collisions, n)
        success_low, success_high = wilson_interval(successes, n)
        table.append(
            {
                "agent": agent,
                "factor": factor,
                "level": level,
                "episodes": n,
                "collisions": collisions,
                "collision_rate": collisions / n,
                "ci_low": low,
                "ci_high": high,
                "success_rate": successes / n,
                "success_ci_low": success_low,
                "success_ci_high": success_high,
                "median_progress_m": float(np.median([m["progress_m"] for m in members])),
                "median_min_clearance_m": float(np.median([m["min_clearance_m"] for m in members])),
            }
        )
    return table


def format_summary(table: list[Mapping[str, Any]]) -> str:
    """The summary as a Markdown table."""
    header = "| agent | factor | level | episodes | collision rate [95 % CI] | success rate [95 % CI] | median progress (m) |"
    lines = [header, "|---|---|---|---|---|---|---|"]
    for r in table:
        lines.append(
            f"| {r['agent']} | {r['factor']} | {r['level']:g} | {r['episodes']} | "
            f"{r['collision_rate']:.2f} [{r['ci_low']:.2f}, {r['ci_high']:.2f}] | "
            f"{r['success_rate']:.2f} [{r['success_ci_low']:.2f}, {r['success_ci_high']:.2f}] | "
            f"{r['median_progress_m']:.1f} |"
        )
    return "\n".join(lines)
