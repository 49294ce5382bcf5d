"""Tunes the bee agent's gains on training seeds only (never on the evaluation seeds from 1,000,000 on).

A small random search around the defaults: each candidate flies the same training layouts, scored by success
rate, then by fewer collisions. Every episode is appended to a CSV as it ends (re-running resumes), and the
ranking is written as Markdown. Run: ``python -m agents.tune_bee --candidates 12 --seeds 20``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from agents.evaluation import EVAL_SEED_START

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


def main(argv: list[str] | None = None) -> int:
    from agents.episodes import EpisodeTask, execute
    from agents.evaluation import read_records, summarise

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--candidates", type=int, default=12)
    parser.add_argument("--seeds", type=int, default=20, help="training seeds 0..N-1 per candidate")
    parser.add_argument("--env-id", default="FlowNav-v0")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default="results/bee_tuning")
    args = parser.parse_args(argv)
    if args.seeds >= EVAL_SEED_START:
        raise ValueError(f"--seeds must stay below the evaluation seeds ({EVAL_SEED_START})")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    grid = candidates(args.candidates, seed=0)
    tasks = [
        # The candidate's index is the record's "level", so rows of different gains never share a key.
        EpisodeTask("bee", "candidate", float(i), seed, args.env_id, bee_params=tuple(sorted(gains.items())))
        for i, gains in enumerate(grid)
        for seed in range(args.seeds)
    ]
    execute(tasks, out / "episodes.csv", workers=args.workers, description="tune bee")
    table = summarise(read_records(out / "episodes.csv"))
    ranked = sorted(table, key=lambda r: (-r["success_rate"], r["collision_rate"]))
    lines = [
        f"# Bee gain tuning on training seeds 0-{args.seeds - 1} ({args.env_id})",
        "",
        f"Command: `python -m agents.tune_bee --candidates {args.candidates} --seeds {args.seeds}`",
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
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
