"""The machine a result was rendered and measured on, for every report (sweeps, the leaderboard, speed
benchmarks, the replication): its CPU, library versions and OpenGL renderer. Above the bottom layer because it
asks the env's renderer; the commit and the CPU alone are :mod:`agents.common.machine`'s."""

from __future__ import annotations

import os
import platform

import cv2

from agents.common.machine import available_cores, cpu_model
from flownav_env.rendering import gl_renderer_name

SOFTWARE_RASTERISERS = ("llvmpipe", "softpipe", "swrast", "lavapipe", "software")


def gl_renderer() -> str:
    """The OpenGL renderer MuJoCo draws with (see :func:`flownav_env.rendering.gl_renderer_name`).

    Recorded with every result because rendered pixels, and so the estimator's corners, differ slightly
    between renderers.
    """
    return gl_renderer_name()


def is_software_renderer(renderer: str) -> bool:
    """Whether a renderer name from :func:`gl_renderer` is a CPU rasteriser (rendering then dominates a step)."""
    return any(word in renderer.lower() for word in SOFTWARE_RASTERISERS)


def machine_summary() -> str:
    """One line: CPU, cores, Python, MuJoCo and OpenCV versions, the GL backend and its renderer."""
    # Here, not at the top: flownav_env (imported above) picks the GL backend before mujoco is first imported.
    import mujoco

    return (
        f"{cpu_model()}, {available_cores()} cores, Python {platform.python_version()}, "
        f"MuJoCo {mujoco.__version__}, OpenCV {cv2.__version__}, MUJOCO_GL={os.environ.get('MUJOCO_GL')} "
        f"({gl_renderer()})"
    )
