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


# The vector instruction sets a policy's float kernels pick between, widest first: the one a CPU has decides
# the order of its sums, so a learned policy's actions differ in their last bits between them.
VECTOR_SETS = ("avx512f", "avx2", "avx", "sse4_2", "asimd", "neon")


def cpu_signature() -> str:
    """The CPU's vendor, architecture and widest vector instruction set (``AuthenticAMD x86_64 avx2``): what
    decides whether a learned policy's episodes re-fly bit for bit on another machine."""
    fields: dict[str, str] = {}
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.is_file():
        for line in cpuinfo.read_text().splitlines():
            name, _, value = line.partition(":")
            fields.setdefault(name.strip(), value.strip())
    vendor = fields.get("vendor_id") or fields.get("CPU implementer") or "unknown vendor"
    flags = set((fields.get("flags") or fields.get("Features") or "").split())
    vector = next((name for name in VECTOR_SETS if name in flags), "no vector set")
    return f"{vendor} {platform.machine() or 'unknown architecture'} {vector}"


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
