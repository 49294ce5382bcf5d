"""Tunes the bee agent's gains on training seeds only (seeds below the validation range, :mod:`agents.common.seeds`).

A small random search around the defaults: each candidate flies the same training layouts, scored by success
rate, then by fewer collisions. Every episode is appended to a CSV as it ends (re-running resumes), and the
ranking is written as Markdown. Run: ``flownav tune-bee --candidates 12 --seeds 20``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from agents.common.seeds import VALIDATION_SEED_START
from agents.evaluation.records import read_records, start_new_file
from agents.evaluation.runner import EpisodeTask, execute, rows_of
from agents.evaluation.statistics import summarise

SEARCH_SPACE = {
    "centring_gain": (0.5, 4.0),
    "frontal_gain": (0.5, 6.0),
    "frontal_threshold": (0.05, 0.4),
    "yaw_gain": (0.0, 1.5),
}


# The hand-set gains the search started from (fixed, so candidate indices in a resumed CSV keep their meaning).
HAND_SET_START = {"centring_gain": 1.5, "frontal_gain": 2.0, "frontal_threshold": 0.15, "yaw_gain": 0.5}


def candidates(count: int, seed: int) -> list[dict[str, float]]:
    """The hand-set start first, then ``count - 1`` log-uniform draws from :data:`SEARCH_SPACE`."""
    rng = np.random.default_rng(seed)
    drawn = [dict(HAND_SET_START)]
    for _ in range(count - 1):
        drawn.append(
            {
                name: round(float(np.exp(rng.uniform(np.log(max(low, 1e-2)), np.log(high)))), 3)
                for name, (low, high) in SEARCH_SPACE.items()
            }
        )
    return drawn


def tune_bee(
    candidate_count: int,
    seed_count: int,
    out: Path,
    *,
    env_id: str = "FlowNav-v0",
    workers: int = 2,
    overwrite: bool = False,
) -> list[str]:
    """Fly every candidate on training seeds ``0 .. seed_count - 1``, resumably, and write ``ranking.md`` and
    ``best.json`` to ``out``; returns the ranking's Markdown lines. ``overwrite`` moves an existing
    ``episodes.csv`` to ``episodes.csv.bak-<time>`` first (for one of other settings or from before episode
    identities, which resuming refuses).

    Raises:
        ValueError: ``seed_count`` reaches into the validation seeds, or a count is below 1.
    """
    if candidate_count < 1 or seed_count < 1:
        raise ValueError(f"--candidates and --seeds must be >= 1, got {candidate_count} and {seed_count}")
    if seed_count > VALIDATION_SEED_START:
        raise ValueError(
            f"--seeds must stay within the training seeds [0, {VALIDATION_SEED_START}), got {seed_count}"
        )
    out.mkdir(parents=True, exist_ok=True)
    if overwrite and (moved := start_new_file(out / "episodes.csv")) is not None:
        print(f"--overwrite: moved {out / 'episodes.csv'} to {moved}")
    grid = candidates(candidate_count, seed=0)
    tasks = [
        # The candidate's index is the record's "level", so rows of different gains never share a key.
        EpisodeTask("bee", "candidate", float(i), seed, env_id, bee_params=tuple(sorted(gains.items())))
        for i, gains in enumerate(grid)
        for seed in range(seed_count)
    ]
    execute(tasks, out / "episodes.csv", workers=workers, description="tune bee")
    # Only this run's episodes: a CSV of an earlier, longer run may hold more candidates or seeds.
    table = summarise(rows_of(tasks, read_records(out / "episodes.csv")))
    ranked = sorted(table, key=lambda r: (-r["success_rate"], r["collision_rate"]))
    lines = [
        f"# Bee gain tuning on training seeds 0-{seed_count - 1} ({env_id})",
        "",
        f"Command: `flownav tune-bee --candidates {candidate_count} --seeds {seed_count}`",
        "",
        "| rank | candidate | success | collision | " + " | ".join(SEARCH_SPACE) + " |",
        "|---|---|---|---|" + "---|" * len(SEARCH_SPACE),
    ]
    for rank, row in enumerate(ranked, 1):
        gains = grid[int(row["level"])]
        lines.append(
            f"| {rank} | {int(row['level'])} | {row['success_rate']:.2f} | {row['collision_rate']:.2f} | "
            + " | ".join(f"{gains[name]:g}" for name in SEARCH_SPACE)
            + " |"
        )
    (out / "ranking.md").write_text("\n".join(lines) + "\n")
    best = grid[int(ranked[0]["level"])]
    (out / "best.json").write_text(json.dumps(best, indent=2))
    return lines
