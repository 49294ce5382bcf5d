"""Learning curves: held-out evaluation return against environment steps, one line per training run."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np


def run_label(evaluations: Path) -> str:
    """``results/policies/ppo_flow_evaluations.npz`` → ``ppo_flow``; ``runs/ppo_flow/evaluations.npz`` →
    ``ppo_flow``."""
    stem = evaluations.stem
    return stem.removesuffix("_evaluations") if stem != "evaluations" else evaluations.parent.name


def plot_learning_curves(
    curves: Mapping[str, Path], output: Path, title: str = "held-out evaluation"
) -> None:
    """One line per run (mean return over the evaluation episodes); a single run also gets its min–max band
    (with several, the overlapping bands hide the lines)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 3.6))
    for label, path in curves.items():
        data = np.load(path)
        steps, returns = data["timesteps"], data["results"]
        line = ax.plot(steps, returns.mean(axis=1), marker="o", markersize=3, label=label)[0]
        if len(curves) == 1:
            ax.fill_between(
                steps, returns.min(axis=1), returns.max(axis=1), color=line.get_color(), alpha=0.2
            )
    ax.set_xlabel("environment steps")
    ax.set_ylabel("episode return (mean)" if len(curves) > 1 else "episode return (mean; band: min–max)")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    output.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(output, dpi=120)
    plt.close(fig)
