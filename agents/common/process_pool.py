"""Work items across worker processes, each with its own pipe: a worker that dies is noticed, and stopping the
workers never waits without bound.

``multiprocessing.Pool`` shares one task queue, guarded by a semaphore, between its workers, and
``Pool.terminate()`` sends SIGTERM and then joins each worker without a time limit. A worker whose SIGTERM handler
is Python code (ours ends its outside agents' processes) can miss that SIGTERM: when the signal lands just before
the worker blocks on the queue's semaphore, the handler is due to run at the next bytecode, but the worker sleeps
in ``sem_wait`` and never reaches one, so it lives on and ``terminate()`` waits for it forever. Seen here with
``py-spy``: the parent in ``Pool._terminate_pool`` joining a worker asleep in ``SemLock.__enter__`` with its
SIGTERM handler installed; that is how a test of a run stopped by an outside agent's exit timed out in CI. A
worker that dies mid-item also loses that item, and the pool then waits for it forever.

Here each worker has a pipe of its own, and the parent waits on every pipe and every worker's exit at once. To
stop, the parent closes the pipes (an idle worker reads their end and returns), sends SIGTERM, waits at most
:data:`STOP_WAIT_S`, then sends SIGKILL: nothing waits without bound.
"""

from __future__ import annotations

import multiprocessing
import signal
import time
from collections.abc import Callable, Iterable, Iterator
from multiprocessing.connection import Connection, wait
from multiprocessing.process import BaseProcess
from typing import Any, NoReturn, TypeVar, cast

Item = TypeVar("Item")
Result = TypeVar("Result")
_NONE_LEFT: Any = object()

# How long a worker sent SIGTERM may take to end (its handler ends what it started) before it is killed.
STOP_WAIT_S = 5.0


class WorkerProcessDied(ChildProcessError):
    """A worker process ended while it held an item, without sending its result: one line naming the item and
    how the worker ended. An OSError: the machine's (or a library's) to fix, not the input's."""


def _exit_words(exitcode: int | None) -> str:
    if exitcode is not None and exitcode < 0 and -exitcode in signal.valid_signals():
        return f"killed by {signal.Signals(-exitcode).name}"
    return f"exit code {exitcode}"


def _serve(
    connection: Connection, function: Callable[[Item], Result], initializer: Callable[[], None] | None
) -> None:
    """A worker's loop: run ``function`` on each item the parent sends until it closes the pipe; send back
    ``(True, result)`` or ``(False, exception)``."""
    if initializer is not None:
        initializer()
    while True:
        try:
            item = connection.recv()
        except (EOFError, OSError):
            return
        try:
            reply: tuple[bool, object] = (True, function(item))
        except Exception as error:  # sent to the parent, which raises it there
            reply = (False, error)
        try:
            connection.send(reply)
        except OSError:  # the parent closed the pipe: it is stopping
            return
        except Exception as error:  # a result or exception that does not pickle: say so as a line
            connection.send((False, RuntimeError(f"{type(error).__name__}: {error} (sending {reply[1]!r})")))


def run_in_workers(
    function: Callable[[Item], Result],
    items: Iterable[Item],
    workers: int,
    *,
    initializer: Callable[[], None] | None = None,
    describe: Callable[[Item], str] = repr,
) -> Iterator[Result]:
    """``function(item)`` for every item, in ``workers`` processes (forkserver: a forked child would inherit this
    process's GL state, which hangs EGL), as each ends, in the order they end.

    ``function``, ``initializer`` and the items must pickle. Closing the iterator (or an exception in it)
    stops every worker: SIGTERM, :data:`STOP_WAIT_S`, then SIGKILL.

    Raises:
        Exception: the first exception ``function`` raised in a worker, as raised there.
        WorkerProcessDied: a worker ended while it held an item; the message names the item (``describe``).
    """
    context = multiprocessing.get_context("forkserver")
    todo = iter(items)
    processes: list[BaseProcess] = []
    connections: list[Connection] = []
    held: dict[Connection, tuple[BaseProcess, Item]] = {}
    try:
        for _ in range(workers):
            item = next(todo, _NONE_LEFT)
            if item is _NONE_LEFT:
                break
            ours, theirs = context.Pipe()
            process: BaseProcess = context.Process(
                target=_serve, args=(theirs, function, initializer), daemon=True
            )
            process.start()
            theirs.close()
            processes.append(process)
            connections.append(ours)
            _hand(ours, process, item, describe)
            held[ours] = (process, item)
        while held:
            by_sentinel = {process.sentinel: connection for connection, (process, _) in held.items()}
            for ready in wait([*held, *by_sentinel]):
                connection = by_sentinel[ready] if isinstance(ready, int) else ready
                if connection not in held:
                    continue  # its pipe and its exit were both ready: handled once
                process, item = held.pop(connection)
                ok, value = _reply(connection, process, item, describe)
                if not ok:
                    raise cast(BaseException, value)  # what _serve sends when function raised
                following = next(todo, _NONE_LEFT)
                if following is _NONE_LEFT:
                    connection.close()  # done: the worker reads the end of its pipe and returns
                else:
                    _hand(connection, process, following, describe)
                    held[connection] = (process, following)
                yield cast(Result, value)  # what _serve sends when function returned
    finally:
        for connection in connections:
            connection.close()
        stop_processes(processes)


def _hand(connection: Connection, process: BaseProcess, item: Item, describe: Callable[[Item], str]) -> None:
    """Send ``item`` to the worker, or raise :class:`WorkerProcessDied` when it has ended."""
    try:
        connection.send(item)
    except OSError:
        _died(process, item, describe)


def _reply(
    connection: Connection, process: BaseProcess, item: Item, describe: Callable[[Item], str]
) -> tuple[bool, object]:
    """The worker's reply about ``item``, or :class:`WorkerProcessDied` when it ended without one: whether
    ``function`` returned, and what it returned or raised (unpickled, so typed by the caller)."""
    try:
        if connection.poll():
            return connection.recv()
    except (EOFError, OSError):
        pass
    _died(process, item, describe)


def _died(process: BaseProcess, item: Item, describe: Callable[[Item], str]) -> NoReturn:
    process.join(STOP_WAIT_S)
    raise WorkerProcessDied(
        f"a worker process ended ({_exit_words(process.exitcode)}) before it finished {describe(item)}; the "
        "run stopped and that one is not recorded"
    )


def stop_processes(processes: Iterable[BaseProcess], wait_s: float = STOP_WAIT_S) -> None:
    """End every process still running: SIGTERM (its handler ends what it started), a wait of at most ``wait_s``
    in all, then SIGKILL for any left."""
    running = [process for process in processes if process.exitcode is None]
    for process in running:
        process.terminate()
    deadline = time.monotonic() + wait_s
    for process in running:
        process.join(max(0.0, deadline - time.monotonic()))
        if process.exitcode is None:
            process.kill()
            process.join()
