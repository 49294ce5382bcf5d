"""What both speed benchmarks share: a timed block without garbage collection, and the report's hardware lines.

Timings are wall-clock on whatever machine runs them; every measurement is taken as a ratio against a
baseline run in the same process, alternated with it, and quoted as a median over repeats, so that a machine
shared with other jobs shifts both sides alike.
"""

from __future__ import annotations

import gc
import os
import platform
from collections.abc import Iterator
from contextlib import contextmanager

from agents.common.machine import code_version, cpu_model
from agents.evaluation.provenance import gl_renderer, is_software_renderer


@contextmanager
def quiet_gc() -> Iterator[None]:
    """No garbage collection inside a timed block: a collection there would be charged to that side of the
    comparison alone; collect between blocks instead."""
    gc.collect()
    gc.disable()
    try:
        yield
    finally:
        gc.enable()


def hardware_summary(renderer: str | None = None) -> str:
    """CPU model, core count, load and GL renderer facts for the report header (one Markdown list).
    ``renderer``: :func:`agents.common.machine.gl_renderer`'s answer where the caller already asked for it."""
    lines = [f"- Python {platform.python_version()} on {platform.system()} {platform.release()}"]
    lines.append(f"- CPU: {cpu_model()}; `nproc` = {os.cpu_count()}")
    try:
        load = ", ".join(f"{value:.2f}" for value in os.getloadavg())
        lines.append(f"- load average (1, 5, 15 min) at the end of the run: {load}")
    except OSError:
        pass
    renderer = renderer if renderer is not None else gl_renderer()
    kind = "software rasterisation on the CPU" if is_software_renderer(renderer) else "hardware rendering"
    lines.append(f"- `MUJOCO_GL={os.environ.get('MUJOCO_GL', '')}`; OpenGL renderer: {renderer} ({kind})")
    lines.append(f"- code: {code_version()}")
    return "\n".join(lines)
