"""What machine a result came from, for every report (benchmarks, sweeps, training records, replication)."""

from __future__ import annotations

import os
import platform
from pathlib import Path


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


def machine_summary() -> str:
    """One line: CPU, cores, Python, MuJoCo and OpenCV versions and the GL backend."""
    import cv2
    import mujoco

    return (
        f"{cpu_model()}, {available_cores()} cores, Python {platform.python_version()}, "
        f"MuJoCo {mujoco.__version__}, OpenCV {cv2.__version__}, MUJOCO_GL={os.environ.get('MUJOCO_GL')}"
    )
