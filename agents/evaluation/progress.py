"""What a run says before it flies, and its progress bars while it does.

Before flying, a run split by factor (a suite's tiers) says what its CSV already holds of each and what is
left. Its bars are one over the run and one per factor, each with an ETA from its own average pace: tiers cost
very different times per episode (a noisy tier's estimator works harder), so one bar's recent pace swings as
the run moves from one tier to the next, while a tier's own pace holds.

Where stderr is no terminal (a log file, a pipe, CI) the bars, whose redrawing writes carriage returns and
cursor moves into the file, give way to plain lines (:class:`PlainProgress`): one per tenth of the run or
minute, and one as each factor finishes.
"""

from __future__ import annotations

import sys
import time
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import TextIO

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


# Each plain progress line starts with this, so a log reader (or a test) tells them from the run's messages.
PROGRESS_PREFIX = "[progress] "


def _clock(seconds: float) -> str:
    """``seconds`` as ``m:ss``, or ``h:mm:ss`` from an hour."""
    minutes, whole = divmod(round(seconds), 60)
    return f"{minutes // 60}:{minutes % 60:02d}:{whole:02d}" if minutes >= 60 else f"{minutes}:{whole:02d}"


class PlainProgress:
    """The run's progress as plain lines on ``stream``: one at each tenth of the run or after ``every_s``
    seconds, whichever comes first, with the time left from the average pace; one as each factor finishes."""

    def __init__(
        self,
        todo: Sequence[EpisodeTask],
        description: str,
        *,
        by_factor: bool = False,
        stream: TextIO | None = None,
        every_s: float = 60.0,
    ) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.description, self.every_s = description, every_s
        self.total = len(todo)
        self.counts = Counter(task.factor for task in todo) if by_factor else Counter()
        self.done: Counter[str] = Counter()
        self.count = 0
        self.start = self.last_line = self.last_done = time.time()
        self.factor_start: dict[str, float] = {}
        self.note = ""

    def _say(self, text: str) -> None:
        print(PROGRESS_PREFIX + text, file=self.stream, flush=True)

    def update(self, factor: str | None) -> None:
        """One more episode done (of ``factor``, where known)."""
        now = time.time()
        self.count += 1
        if factor is not None and factor in self.counts and len(self.counts) > 1:
            # A factor's time runs from when the episode before its first ended, as its bar's does.
            self.factor_start.setdefault(factor, self.last_done)
            self.done[factor] += 1
            if self.done[factor] == self.counts[factor]:
                took = _clock(now - self.factor_start[factor])
                self._say(f"  {factor}: {self.done[factor]}/{self.counts[factor]} episodes done in {took}")
        tenth = max(1, self.total // 10)
        if self.count == self.total or self.count % tenth == 0 or now - self.last_line >= self.every_s:
            elapsed = now - self.start
            left = elapsed / self.count * (self.total - self.count)
            note = f" ({self.note})" if self.note else ""
            self._say(
                f"{self.description}: {self.count}/{self.total} episodes, {100 * self.count // max(self.total, 1)} %, "
                f"{_clock(elapsed)} elapsed, about {_clock(left)} left{note}"
            )
            self.last_line = now
        self.last_done = now

    def set_postfix_str(self, text: str) -> None:
        """A note on the next line (what the run waits for)."""
        self.note = text

    def close(self) -> None:
        """Nothing is left open: each line was written whole."""


def episode_progress(
    todo: Sequence[EpisodeTask], description: str, *, by_factor: bool = False
) -> EpisodeProgress | PlainProgress:
    """Bars where stderr is a terminal, plain lines where it is not (:class:`PlainProgress`)."""
    if sys.stderr.isatty():
        return EpisodeProgress(todo, description, by_factor=by_factor)
    return PlainProgress(todo, description, by_factor=by_factor)


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
