"""What the speed benchmarks share: a timed block without garbage collection, the report's hardware lines, and
the writers of their tables, figures (the thesis replication's too) and reports.

Timings are wall-clock on whatever machine runs them; every measurement is taken as a ratio against a
baseline run in the same process, alternated with it, and quoted as a median over repeats, so that a machine
shared with other jobs shifts both sides alike.
"""

from __future__ import annotations

import gc
import math
import os
import platform
import time
from collections.abc import Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager, suppress
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from agents.common.jinja_reports import render
from agents.common.machine import available_cores, code_version, cpu_model
from agents.common.tables import markdown_table, today
from agents.evaluation.provenance import gl_renderer, is_software_renderer

if TYPE_CHECKING:
    from _typeshed import DataclassInstance
    from matplotlib.figure import Figure

PACKAGE = "agents.studies.perf"
TEMPLATES = Path(__file__).with_name("templates")


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


def median(values: Sequence[float] | np.ndarray) -> float:
    """The median, NaN for no values."""
    return float(np.median(values)) if len(values) else math.nan


def interval(name: str, values: Sequence[float], prefix: str = "") -> dict[str, float]:
    """``name``: the median of ``values`` (a ratio block by block or pass by pass); ``<prefix>_min`` and
    ``<prefix>_max`` (``prefix`` defaults to ``name``): their range."""
    prefix = prefix or name
    return {name: median(values), f"{prefix}_min": min(values), f"{prefix}_max": max(values)}


@dataclass(frozen=True)
class RunFacts:
    """What every speed report states about its run (``run`` in the templates): the command, when it was
    written, how long it took, and the machine (a Markdown list of CPU, load, GL renderer and code version; its
    cores; whether MuJoCo rendered on the CPU)."""

    command: str
    elapsed_s: float
    generated: str
    hardware: str
    cores: int
    software_renderer: bool

    @classmethod
    def of_this_run(cls, command: str, started: float) -> RunFacts:
        """The facts of a run begun at ``time.perf_counter()`` = ``started``, on this machine, now."""
        renderer = gl_renderer()
        elapsed = time.perf_counter() - started
        kind = "software rasterisation on the CPU" if is_software_renderer(renderer) else "hardware rendering"
        lines = [f"- Python {platform.python_version()} on {platform.system()} {platform.release()}"]
        lines.append(f"- CPU: {cpu_model()}; `nproc` = {os.cpu_count()}")
        with suppress(OSError):  # no load average on this platform
            load = ", ".join(f"{value:.2f}" for value in os.getloadavg())
            lines.append(f"- load average (1, 5, 15 min) at the end of the run: {load}")
        lines.append(f"- `MUJOCO_GL={os.environ.get('MUJOCO_GL', '')}`; OpenGL renderer: {renderer} ({kind})")
        lines.append(f"- code: {code_version()}")
        return cls(
            command, elapsed, today(), "\n".join(lines), available_cores(), is_software_renderer(renderer)
        )

    @property
    def elapsed(self) -> str:
        return f"{self.elapsed_s:.0f}"

    @property
    def elapsed_min(self) -> str:
        return f"{self.elapsed_s / 60:.1f}"


def table(
    rows: Iterable[Mapping[str, object]], columns: Mapping[str, str] | Sequence[tuple[str, str]]
) -> str:
    """A Markdown table with one column per ``header: format`` entry (pairs where headers repeat); each cell is
    ``format.format_map(row)``."""
    pairs = list(columns.items()) if isinstance(columns, Mapping) else list(columns)
    return markdown_table(
        [h for h, _ in pairs], [[cell.format_map(row) for _, cell in pairs] for row in rows]
    )


def rounded(rows: Iterable[Mapping[str, object]]) -> list[dict[str, object]]:
    """The rows with their floats rounded to four decimals, for a CSV file."""
    return [{key: round(v, 4) if isinstance(v, float) else v for key, v in row.items()} for row in rows]


def write_report(path: Path, template: str, values: DataclassInstance) -> Path:
    """``templates/<template>`` filled with ``values`` (every one of them used), written to ``path``."""
    path.write_text(render(PACKAGE, template, values, every_value_used=True))
    return path


@contextmanager
def saved_figure(
    path: Path,
    size: tuple[float, float],
    dpi: int = 110,
    rect: tuple[float, float, float, float] = (0, 0, 1, 1),
) -> Iterator[Figure]:
    """A matplotlib figure of ``size`` inches, laid out tight within ``rect`` (the figure's fraction the axes
    may fill) and saved to ``path`` (its folder created) when the block ends."""
    # matplotlib is imported here: it is slow to import and only the figures need it.
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure = plt.figure(figsize=size)
    try:
        yield figure
        figure.tight_layout(rect=rect)
        path.parent.mkdir(parents=True, exist_ok=True)
        figure.savefig(path, dpi=dpi)
    finally:
        plt.close(figure)
