"""The thesis experiments' figures: estimated depth against the ground-truth line of each obstacle."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from agents.studies.perf.report_kit import saved_figure
from agents.studies.thesis.metrics import FrameRow

if TYPE_CHECKING:  # matplotlib is slow to import: the figures import it when they draw
    from matplotlib.axes import Axes

# Depths plotted up to this many metres: the scenes' obstacles stand within 10 m.
PLOT_MAX_DEPTH = 10.0


_OBSTACLE_COLOURS = ("tab:red", "tab:blue", "tab:green", "tab:orange", "tab:purple", "tab:brown")


def plot_depth_panel(ax: Axes, frames: list[FrameRow], references: np.ndarray, title: str) -> None:
    """The thesis's plot style: each valid point's depth per frame, against each obstacle's true depth line.

    Points on a capsule take the capsule's colour; ground points are grey. Lines are the ground truth.
    """
    for index, frame in enumerate(frames):
        valid = np.asarray(frame["valid"], bool)
        labels = np.asarray(frame["labels"])
        depth = np.asarray(frame["depth"])
        ground = valid & (labels < 0)
        if ground.any():
            ax.scatter(np.full(ground.sum(), index), depth[ground], s=2, c="0.7", linewidths=0)
        for k in range(references.shape[1] if references.ndim == 2 else 0):
            on = valid & (labels == k)
            if on.any():
                colour = _OBSTACLE_COLOURS[k % len(_OBSTACLE_COLOURS)]
                ax.scatter(np.full(on.sum(), index), depth[on], s=3, c=colour, linewidths=0)
    if references.size:
        for k in range(references.shape[1]):
            colour = _OBSTACLE_COLOURS[k % len(_OBSTACLE_COLOURS)]
            ax.plot(
                np.arange(len(references)),
                references[:, k],
                c=colour,
                lw=1.5,
                label=f"capsule {k + 1} (truth)",
            )
    ax.set_ylim(0.0, PLOT_MAX_DEPTH)
    ax.set_xlabel("frame")
    ax.set_ylabel("depth (m)")
    ax.set_title(title, fontsize=9)
    ax.grid(alpha=0.3)


def save_depth_figure(
    panels: list[tuple[str, list[FrameRow], np.ndarray]],
    file: Path,
    suptitle: str,
    marks: dict[int, float] | None = None,
) -> Path:
    """A figure of :func:`plot_depth_panel` panels; ``marks`` draws a dashed line at a frame in some panels."""
    columns = 2
    rows = math.ceil(len(panels) / columns)
    with saved_figure(file, (5.0 * columns, 3.4 * rows), rect=(0, 0.05, 1, 0.97)) as fig:
        axes = fig.subplots(rows, columns, squeeze=False)
        for index, (ax, (title, frames, references)) in enumerate(zip(axes.flat, panels, strict=False)):
            plot_depth_panel(ax, frames, references, title)
            if marks and index in marks:
                ax.axvline(marks[index], c="k", ls="--", lw=0.8)
        for ax in list(axes.flat)[len(panels) :]:
            ax.axis("off")
        handles, labels = axes.flat[0].get_legend_handles_labels()
        if handles:
            fig.legend(handles, labels, loc="lower center", ncol=min(len(handles), 4), fontsize=8)
        fig.suptitle(suptitle, fontsize=10)
    return file
