"""Learning curves: held-out evaluation return against environment steps, one line per training run, or one
panel per config with its training seeds; and reading the ``evaluations.npz`` they are drawn from."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np


def run_label(evaluations: Path) -> str:
    """``results/policies/ppo_flow_evaluations.npz`` → ``ppo_flow``; ``runs/ppo_flow/evaluations.npz`` →
    ``ppo_flow``."""
    stem = evaluations.stem
    return stem.removesuffix("_evaluations") if stem != "evaluations" else evaluations.parent.name


def _evaluations_problem(timesteps: np.ndarray, results: np.ndarray, lengths: np.ndarray) -> str | None:
    """What is wrong with the arrays of an ``evaluations.npz``, or None when they fit together."""
    if not all(np.issubdtype(array.dtype, np.number) for array in (timesteps, results, lengths)):
        return "its arrays are not numbers"
    if timesteps.ndim != 1 or results.ndim != 2 or results.shape[1] == 0:
        return f"timesteps of shape {timesteps.shape} and results of shape {results.shape} are not one row per step"
    if results.shape[0] != len(timesteps) or lengths.shape != results.shape:
        return (
            f"{len(timesteps)} timesteps, results of shape {results.shape} and ep_lengths of shape "
            f"{lengths.shape} do not match"
        )
    return None


def read_evaluations(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The steps, per-episode returns and episode lengths of an ``evaluations.npz`` (SB3's layout).

    Raises:
        ValueError: the file does not hold them: empty, cut short, not an archive, or arrays of other names,
            types or shapes; the message says what is wrong.
    """
    try:
        with np.load(path, allow_pickle=False) as saved:
            timesteps, results, lengths = (
                np.asarray(saved[key]) for key in ("timesteps", "results", "ep_lengths")
            )
    except Exception as error:  # numpy and zipfile raise many types for a damaged file; all mean unreadable
        raise ValueError(f"{type(error).__name__}: {error}") from None
    problem = _evaluations_problem(timesteps, results, lengths)
    if problem is not None:
        raise ValueError(problem)
    return timesteps, results, lengths


def load_curve(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """The steps and per-episode returns of an ``evaluations.npz``.

    Raises:
        ValueError: the file is damaged or not an evaluations file; one line naming it and what is wrong.
    """
    try:
        steps, returns, _ = read_evaluations(path)
    except ValueError as problem:
        raise ValueError(f"evaluations file {path} is unreadable: {problem}") from None
    return steps, returns


def plot_learning_curves(
    curves: Mapping[str, Path], output: Path, title: str = "held-out evaluation"
) -> None:
    """One line per run (mean return over the evaluation episodes); a single run also gets its min–max band
    (with several, the overlapping bands hide the lines)."""
    # matplotlib is heavy: imported only when a curve is drawn, not by training's imports.
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 3.6))
    for label, path in curves.items():
        steps, returns = load_curve(path)
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


def plot_grouped_learning_curves(
    groups: Mapping[str, Mapping[str, Path]], output: Path, title: str = "held-out evaluation"
) -> None:
    """One panel per group (a config), sharing the return axis: a thin line per run (a training seed) and
    their mean, thick, over the evaluations every run reached. With a dozen runs or more in one axis the
    colours repeat and the lines cannot be told apart; panels keep each config's seeds together."""
    # matplotlib is heavy: imported only when curves are drawn.
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    if not groups:
        raise ValueError("no learning curves to plot: groups is empty")
    columns = min(3, len(groups))
    rows = -(-len(groups) // columns)
    fig, axes = plt.subplots(
        rows, columns, figsize=(3.6 * columns, 2.7 * rows + 0.5), sharex=True, sharey=True, squeeze=False
    )
    for axis, (group, curves) in zip(axes.flat, groups.items(), strict=False):
        means = []
        for path in curves.values():
            steps, returns = load_curve(path)
            returns = returns.mean(axis=1)
            axis.plot(steps, returns, color="tab:blue", alpha=0.35, linewidth=1)
            means.append((steps, returns))
        reached = min(len(steps) for steps, _ in means)
        mean = np.mean([returns[:reached] for _, returns in means], axis=0)
        axis.plot(means[0][0][:reached], mean, color="tab:blue", linewidth=2.2, label="mean over seeds")
        axis.set_title(f"{group} ({len(curves)} seed{'s' * (len(curves) > 1)})", fontsize=9)
        axis.grid(alpha=0.3)
    for axis in axes.flat[len(groups) :]:
        axis.set_visible(False)
    for axis in axes[-1]:
        axis.set_xlabel("environment steps")
        axis.xaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda value, _: f"{value / 1000:g}k"))
    for axis in axes[:, 0]:
        axis.set_ylabel("mean episode return")
    axes.flat[0].legend(loc="lower right", fontsize=7)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    output.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(output, dpi=120)
    plt.close(fig)
