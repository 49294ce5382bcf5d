"""Writes summary.csv beside this file from the episodes and CPU times fly.sh recorded: per agent and course, the
failures (collision or out of bounds, or the time limit) on the 20 layouts with a Wilson 95 % interval, and the
CPU and wall seconds per episode. Run from the repository root: python results/camera_reference/summarise.py
"""

from __future__ import annotations

import csv
from pathlib import Path

from agents.analysis.records import read_records
from agents.analysis.statistics import wilson_interval

HERE = Path(__file__).parent
AGENTS = ("planner", "planner_camera", "planner_camera_observed")
COURSES = ("clean", "hard")


def summary_rows() -> list[dict[str, object]]:
    """One row per (course, agent) flown by fly.sh."""
    rows: list[dict[str, object]] = []
    for course in COURSES:
        for agent in AGENTS:
            episodes = read_records(HERE / f"{agent}_{course}.csv")
            failed = [str(row["seed"]) for row in episodes if not row["success"]]
            user, system, wall = (
                float(value) for value in (HERE / f"{agent}_{course}.time").read_text().split()
            )
            low, high = wilson_interval(len(failed), len(episodes))
            rows.append(
                {
                    "course": course,
                    "agent": agent,
                    "episodes": len(episodes),
                    "failures": len(failed),
                    "failure_rate": round(len(failed) / len(episodes), 4),
                    "failure_low": round(low, 4),
                    "failure_high": round(high, 4),
                    "failed_seeds": " ".join(failed),
                    "cpu_s_per_episode": round((user + system) / len(episodes), 2),
                    "wall_s_per_episode": round(wall / len(episodes), 2),
                }
            )
    return rows


if __name__ == "__main__":
    table = summary_rows()
    with open(HERE / "summary.csv", "w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=list(table[0]), lineterminator="\n")
        writer.writeheader()
        writer.writerows(table)
