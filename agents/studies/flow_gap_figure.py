"""``flow_gap.png``: failure on flow and on true depths side by side, a panel per recipe (drawn for
:mod:`agents.studies.flow_gap_report`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

Cell = tuple[float, float, float]  # a failure rate and its 95 % interval


def plot_gap(panels: Mapping[str, Sequence[tuple[str, Cell | None, Cell | None]]], path: Path) -> None:
    """A panel per recipe: flow's and truth's failure side by side where each was flown, 95 % intervals."""
    # matplotlib takes a second to import: only the writers that draw a figure load it.
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    widths = [max(1, len(bars)) for bars in panels.values()]
    fig, axes = plt.subplots(
        1,
        len(panels),
        figsize=(1.0 + 0.9 * sum(widths), 4.0),
        gridspec_kw={"width_ratios": widths},
        squeeze=False,
    )
    for ax, (title, bars) in zip(axes[0], panels.items(), strict=True):
        for offset, (flow, colour, name) in (
            (-0.2, (True, "tab:blue", "flow")),
            (0.2, (False, "tab:orange", "true depths")),
        ):
            xs: list[float] = []
            ys: list[float] = []
            errors: list[list[float]] = [[], []]
            for x, (_, flow_cell, truth_cell) in enumerate(bars):
                cell = flow_cell if flow else truth_cell
                if cell is not None:
                    xs.append(x + offset)
                    ys.append(cell[0])
                    errors[0].append(cell[0] - cell[1])
                    errors[1].append(cell[2] - cell[0])
            ax.bar(xs, ys, width=0.4, yerr=errors, capsize=3, color=colour, alpha=0.8, label=name)
        ax.set_xticks(range(len(bars)), [bar[0] for bar in bars], rotation=35, ha="right", fontsize=8)
        ax.set_ylim(0, 1)
        ax.set_title(title.replace("`", ""), fontsize=9)
        ax.grid(alpha=0.3, axis="y")
        if not any(bar[2] for bar in bars):
            ax.text(
                0.5, 0.9, "true-depth recipe not trained yet", transform=ax.transAxes, ha="center", fontsize=8
            )
    axes[0][0].set_ylabel("failure rate (95 % CI)")
    axes[0][0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
