"""The camera-limited references' feasibility check on the closed field (``results/camera_reference/``):
``planner``, ``planner_camera`` and ``planner_camera_observed`` fly the same validation layouts of a field of
capsules across the whole lateral bound, on the clean course and the hard one, one process per agent and course,
each with the CPU and wall seconds it took; then a summary of their failures and costs per episode.

These are validation layouts: nothing here is a suite result, and nothing was tuned on them.
"""

from __future__ import annotations

import csv
import resource
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

from agents.analysis.records import read_records
from agents.analysis.statistics import wilson_interval
from agents.common.seeds import CAMERA_REFERENCE_SEED_START

AGENTS = ("planner", "planner_camera", "planner_camera_observed")
# The env settings of each course on the closed field: capsules across the whole ±6 m lateral bound, at the
# clean course's speed and density or at the hard one's.
COURSES: dict[str, tuple[str, ...]] = {
    "clean": ("field_width=12.0",),
    "hard": ("field_width=12.0", "forward_speed=2.0", "obstacle_density=0.18"),
}
LAYOUTS = 20
ENV_ID = "FlowNav-v0"
SUMMARY_CSV = "summary.csv"
# Each run is niced: the check was flown on a machine shared with other work, and its CPU seconds (not its wall
# seconds) are what the summary compares.
_NICENESS = "10"


def evaluate_argv(agent: str, course: str, out_dir: Path) -> list[str]:
    """The ``flownav evaluate`` arguments that fly ``agent`` on ``course`` into ``out_dir``/<agent>_<course>.csv."""
    settings = (*COURSES[course], "depth_error_info=False")
    return [
        "evaluate",
        "--agent",
        agent,
        "--layouts",
        str(LAYOUTS),
        "--seed-start",
        str(CAMERA_REFERENCE_SEED_START),
        "--tiers",
        ENV_ID,
        *(word for setting in settings for word in ("--env", setting)),
        "--out",
        str(out_dir / f"{agent}_{course}.csv"),
    ]


def fly_camera_reference(out_dir: Path, say: Callable[[str], None] = print) -> list[Path]:
    """Fly every agent on every course, each in a process of its own, and write beside its episodes
    ``<agent>_<course>.time``: the process's user and system CPU seconds and its wall seconds. An episodes file
    already there is resumed, as ``flownav evaluate`` resumes it.

    Returns:
        The time files written.

    Raises:
        subprocess.CalledProcessError: a run that failed.
    """
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for course in COURSES:
        for agent in AGENTS:
            argv = evaluate_argv(agent, course, out_dir)
            say(f"flownav {' '.join(argv)}")
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            start = time.perf_counter()
            subprocess.run(
                [
                    "nice",
                    "-n",
                    _NICENESS,
                    sys.executable,
                    "-c",
                    "import sys; from agents.cli import main; sys.exit(main())",
                    *argv,
                ],
                check=True,
            )
            wall = time.perf_counter() - start
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            path = out_dir / f"{agent}_{course}.time"
            path.write_text(
                f"{after.ru_utime - before.ru_utime:.2f} {after.ru_stime - before.ru_stime:.2f} {wall:.2f}\n"
            )
            written.append(path)
    return written


def summary_rows(folder: Path) -> list[dict[str, object]]:
    """One row per course and agent flown into ``folder``: the failures (collision, out of bounds or the time
    limit) over its layouts with a Wilson 95 % interval, the failed seeds, and the CPU and wall seconds per
    episode."""
    rows: list[dict[str, object]] = []
    for course in COURSES:
        for agent in AGENTS:
            episodes = read_records(folder / f"{agent}_{course}.csv")
            failed = [str(row["seed"]) for row in episodes if not row["success"]]
            user, system, wall = (
                float(value) for value in (folder / f"{agent}_{course}.time").read_text().split()
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


def write_summary(folder: Path) -> Path:
    """Write :func:`summary_rows` of ``folder`` to ``folder``/summary.csv and return its path."""
    table = summary_rows(folder)
    path = folder / SUMMARY_CSV
    with open(path, "w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=list(table[0]), lineterminator="\n")
        writer.writeheader()
        writer.writerows(table)
    return path
