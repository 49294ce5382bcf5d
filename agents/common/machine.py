"""What machine a result came from, for every report (benchmarks, sweeps, training records, replication)."""

from __future__ import annotations

import os
import platform
import subprocess
from pathlib import Path

from agents.common.locations import REPO_ROOT


def cpu_model() -> str:
    """The CPU's model name (from /proc/cpuinfo where there is one)."""
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.is_file():
        for line in cpuinfo.read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    return platform.processor() or platform.machine() or "unknown CPU"


def available_cores() -> int:
    """Logical cores this process may use."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def code_version() -> str:
    """The git commit the run used, flagged when the measured packages had uncommitted changes.

    Other work lands on the same branch while benchmarks run, so a result is only reproducible with its commit.
    """
    root = REPO_ROOT

    def git(*args: str) -> str:
        try:
            result = subprocess.run(
                ["git", *args], cwd=root, capture_output=True, text=True, check=False, timeout=10
            )
        except (OSError, subprocess.SubprocessError):
            return ""
        return result.stdout.strip() if result.returncode == 0 else ""

    commit = git("rev-parse", "--short", "HEAD")
    if not commit:
        return "unknown (not a git checkout)"
    dirty = git("status", "--porcelain", "--", "estimator", "flownav_env", "agents")
    return f"commit `{commit}`" + (
        " with uncommitted changes in estimator/, flownav_env/ or agents/" if dirty else ""
    )
