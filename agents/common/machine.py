"""What machine a result came from, for every report (benchmarks, sweeps, training records, replication)."""

from __future__ import annotations

import os
import platform
import subprocess
from pathlib import Path

from agents.common.paths import REPO_ROOT


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


SOFTWARE_RASTERISERS = ("llvmpipe", "softpipe", "swrast", "lavapipe", "software")


def gl_renderer() -> str:
    """The OpenGL renderer MuJoCo draws with (see :func:`flownav_env.rendering.gl_renderer_name`).

    Recorded with every result because rendered pixels, and so the estimator's corners, differ slightly
    between renderers.
    """
    from flownav_env.rendering import gl_renderer_name

    return gl_renderer_name()


def is_software_renderer(renderer: str) -> bool:
    """Whether a renderer name from :func:`gl_renderer` is a CPU rasteriser (rendering then dominates a step)."""
    return any(word in renderer.lower() for word in SOFTWARE_RASTERISERS)


def machine_summary() -> str:
    """One line: CPU, cores, Python, MuJoCo and OpenCV versions, the GL backend and its renderer."""
    import cv2
    import mujoco

    import flownav_env  # noqa: F401  (picks the GL backend before mujoco is imported)

    return (
        f"{cpu_model()}, {available_cores()} cores, Python {platform.python_version()}, "
        f"MuJoCo {mujoco.__version__}, OpenCV {cv2.__version__}, MUJOCO_GL={os.environ.get('MUJOCO_GL')} "
        f"({gl_renderer()})"
    )


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
