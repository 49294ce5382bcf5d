"""Stopping a training run without losing it: SIGTERM and SIGINT both end learning with a saved checkpoint.

A job scheduler, a container or the end of a session stops processes with SIGTERM, and a run started in the
background of a script (``cmd &``) receives SIGINT already ignored, so ``kill -INT`` would do nothing. While
learning, both signals raise ``KeyboardInterrupt`` in the main process, which saves and writes the run
(:func:`agents.training.ppo.train`); the env workers ignore both and are closed by the main process.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


def _raise_interrupt(signum: int, _frame: object) -> None:
    raise KeyboardInterrupt(f"{signal.Signals(signum).name} received")


@contextmanager
def stop_signals_interrupt() -> Iterator[None]:
    """Within the block, SIGINT and SIGTERM raise ``KeyboardInterrupt`` (in the main thread; elsewhere, as in
    a Ray worker thread, signals cannot be handled and the block runs unchanged)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {signum: signal.getsignal(signum) for signum in STOP_SIGNALS}
    for signum in STOP_SIGNALS:
        signal.signal(signum, _raise_interrupt)
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


@contextmanager
def stop_signals_deferred() -> Iterator[None]:
    """Within the block, a SIGINT or SIGTERM is only noted; once the block ends, the first noted one is raised
    again, so the handler in force outside the block acts on it (within learning, :func:`stop_signals_interrupt`
    raises ``KeyboardInterrupt``). For writes that an exception must not cut in two: torch's zip writer,
    interrupted mid-write, fails with its own RuntimeError that hides the stop, and the run would end as failed
    instead of saved. Outside the main thread the block runs unchanged."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    noted: list[int] = []
    previous = {signum: signal.getsignal(signum) for signum in STOP_SIGNALS}
    for signum, handler in previous.items():
        if handler not in (signal.SIG_IGN, None):  # an ignored signal stays ignored
            signal.signal(signum, lambda received, _frame: noted.append(received))
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    if noted:
        signal.raise_signal(noted[0])


def ignore_stop_signals() -> None:
    """For env worker processes: leave stopping to the main process, which closes them after saving."""
    for signum in STOP_SIGNALS:
        signal.signal(signum, signal.SIG_IGN)


def ignore_ctrl_c() -> None:
    """For the processes of seeds trained side by side: Ctrl-C reaches the whole process group, and an idle
    one would die of it; while learning, :func:`stop_signals_interrupt` handles it. SIGTERM keeps its default
    outside learning, so a seed still building its envs when the parent passes a stop on simply ends."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
