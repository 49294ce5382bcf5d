"""What a run says before it flies, and its progress bars while it does.

Before flying, a run split by factor (a suite's tiers) says what its CSV already holds of each and what is
left. Its bars are one over the run and one per factor, each with an ETA from its own average pace: tiers cost
very different times per episode (a noisy tier's estimator works harder), so one bar's recent pace swings as
the run moves from one tier to the next, while a tier's own pace holds.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Sequence
from pathlib import Path

from tqdm import tqdm

from agents.evaluation.episode_tasks import EpisodeTask


def holdings_line(csv_path: Path, tasks: Sequence[EpisodeTask], todo: Sequence[EpisodeTask]) -> str:
    """One line: how many of ``tasks`` the CSV holds already, per factor, and how many are left to fly."""
    total = Counter(task.factor for task in tasks)
    left = Counter(task.factor for task in todo)
    per_factor = ", ".join(
        f"{factor} {total[factor] - left[factor]}/{count}" for factor, count in total.items()
    )
    return (
        f"{csv_path} holds {len(tasks) - len(todo)} of these {len(tasks)} episodes already ({per_factor}); "
        f"{len(todo)} left to fly"
        + ("; each bar's time left is an estimate from the pace of its episodes flown so far" if todo else "")
    )


class EpisodeProgress:
    """A bar over the run's episodes and, with ``by_factor`` and more than one factor, one per factor."""

    def __init__(self, todo: Sequence[EpisodeTask], description: str, *, by_factor: bool = False) -> None:
        # smoothing=0: the ETA comes from the average pace since the bar started, not the last few episodes.
        self.total = tqdm(total=len(todo), desc=description, unit="episode", smoothing=0)
        counts = Counter(task.factor for task in todo)
        self.bars: dict[str, tqdm] = {}
        if by_factor and len(counts) > 1:
            for position, (factor, count) in enumerate(counts.items(), start=1):
                self.bars[factor] = tqdm(
                    total=count, desc=f"  {factor}", unit="episode", smoothing=0, position=position
                )
        self.last_done = time.time()

    def update(self, factor: str | None) -> None:
        """One more episode done (of ``factor``, where known)."""
        now = time.time()
        bar = self.bars.get(factor) if factor is not None else None
        if bar is not None:
            if bar.n == 0:
                # A factor's bar exists from the start but its episodes began about when the last one before
                # them ended: its pace is timed from then, not from the start of the run.
                bar.start_t = self.last_done
            bar.update()
            if bar.n == bar.total:
                bar.close()  # now, so its time and pace stay those of its own episodes
        self.total.update()
        self.last_done = now

    def set_postfix_str(self, text: str) -> None:
        """A note after the run's bar (what it waits for)."""
        self.total.set_postfix_str(text)

    def close(self) -> None:
        """Close every bar."""
        for bar in [*self.bars.values(), self.total]:
            bar.close()
