"""Items across worker processes with a pipe each: every result comes back, a worker's exception is raised
here, a worker that dies is named with its item instead of hanging the run, and stopping never waits without
bound. The work is stdlib functions, so the forkserver's workers import nothing of the tests."""

from __future__ import annotations

import functools
import math
import multiprocessing
import os
import signal
import time

import pytest

from agents.common import process_pool
from agents.common.process_pool import WorkerProcessDied, run_in_workers

# A worker initializer that makes SIGTERM do nothing: only closing its pipe or SIGKILL ends such a worker.
IGNORE_SIGTERM = functools.partial(signal.signal, signal.SIGTERM, signal.SIG_IGN)


def _no_children_left() -> bool:
    return multiprocessing.active_children() == []


def test_every_item_comes_back_once_from_two_workers() -> None:
    results = list(run_in_workers(math.sqrt, [1.0, 4.0, 9.0, 16.0, 25.0], 2))
    assert sorted(results) == [1.0, 2.0, 3.0, 4.0, 5.0]
    assert _no_children_left()


def test_no_items_start_no_workers_and_more_workers_than_items_is_fine() -> None:
    assert list(run_in_workers(math.sqrt, [], 2)) == []
    assert list(run_in_workers(math.sqrt, [4.0], 3)) == [2.0]
    assert _no_children_left()


def test_an_exception_in_a_worker_is_raised_here_and_the_workers_stop() -> None:
    with pytest.raises(ValueError, match="math domain error"):
        list(run_in_workers(math.sqrt, [4.0, -1.0, 9.0], 2))
    assert _no_children_left()


@pytest.mark.parametrize(
    ("function", "item", "how"),
    [(os._exit, 9, "exit code 9"), (signal.raise_signal, signal.SIGKILL, "killed by SIGKILL")],
)
def test_a_worker_that_dies_is_named_with_its_item_instead_of_hanging(function, item, how: str) -> None:
    started = time.monotonic()
    with pytest.raises(WorkerProcessDied) as raised:
        list(run_in_workers(function, [item], 2, describe=lambda x: f"item {x!r}"))
    assert str(raised.value) == (
        f"a worker process ended ({how}) before it finished item {item!r}; the run stopped and that one is not "
        "recorded"
    )
    assert isinstance(raised.value, OSError) and time.monotonic() - started < 60
    assert _no_children_left()


def test_closing_early_stops_a_busy_worker_and_kills_one_that_ignores_sigterm(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(process_pool, "STOP_WAIT_S", 0.5)
    results = run_in_workers(time.sleep, [0.0, 60.0, 60.0], 2, initializer=IGNORE_SIGTERM)
    assert next(results) is None  # time.sleep's result; the other worker now sleeps 60 s
    started = time.monotonic()
    results.close()
    assert time.monotonic() - started < 20  # SIGTERM ignored, so killed after the wait; never the 60 s
    assert _no_children_left()


def test_workers_done_with_their_items_end_by_themselves_without_a_signal(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # They ignore SIGTERM here and the wait before SIGKILL is long: only reading the end of their pipe ends them.
    monkeypatch.setattr(process_pool, "STOP_WAIT_S", 120.0)
    started = time.monotonic()
    assert sorted(run_in_workers(math.sqrt, [1.0, 4.0, 9.0], 2, initializer=IGNORE_SIGTERM)) == [
        1.0,
        2.0,
        3.0,
    ]
    assert time.monotonic() - started < 60 and _no_children_left()


def _sleep_deaf_to_sigterm() -> None:
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    time.sleep(60)


def test_stop_processes_kills_what_ignores_sigterm_within_one_shared_wait() -> None:
    # Fork: the target is this module's function, so nothing is pickled or imported.
    context = multiprocessing.get_context("fork")
    deaf = [context.Process(target=_sleep_deaf_to_sigterm) for _ in range(2)]
    hearing = context.Process(target=time.sleep, args=(60,))
    for process in [*deaf, hearing]:
        process.start()
    time.sleep(0.5)  # the deaf ones have set their handler
    started = time.monotonic()
    process_pool.stop_processes([*deaf, hearing], wait_s=1.0)
    # One wait of 1 s for all of them, not 1 s each; SIGTERM ends the one that hears it, SIGKILL the others.
    assert time.monotonic() - started < 1.9
    assert [process.exitcode for process in deaf] == [-signal.SIGKILL, -signal.SIGKILL]
    assert hearing.exitcode == -signal.SIGTERM


def test_stop_processes_leaves_ended_processes_alone() -> None:
    ended = multiprocessing.get_context("fork").Process(target=time.sleep, args=(0,))
    ended.start()
    ended.join()
    process_pool.stop_processes([ended], wait_s=0.0)
    assert ended.exitcode == 0
