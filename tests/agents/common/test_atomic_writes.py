"""Atomic writes (``agents.common.folders.replacing_atomically``): whole files for readers in other processes,
no temporary left by a failed write, and the file mode other files get."""

from __future__ import annotations

import errno
import hashlib
import multiprocessing
import os
import resource
import signal
from pathlib import Path

import pytest

from agents.common.folders import NEW_FILE_MODE, copy_atomically, replacing_atomically, write_text_atomically

WRITES_PER_PROCESS = 300
BODY_BYTES = 20_000


def _content(writer: int, index: int) -> str:
    """A distinct file that says whether it is whole: a body, then its digest on the last line."""
    body = f"writer {writer} write {index}\n" + chr(ord("a") + (writer * 7 + index) % 26) * BODY_BYTES
    return f"{body}\n{hashlib.sha256(body.encode()).hexdigest()}"


def _is_whole(text: str) -> bool:
    body, _, digest = text.rpartition("\n")
    return hashlib.sha256(body.encode()).hexdigest() == digest


def _write_many(path: Path, writer: int, errors: multiprocessing.Queue) -> None:
    failures = []
    for index in range(WRITES_PER_PROCESS):
        try:
            write_text_atomically(path, _content(writer, index))
        except OSError as error:
            failures.append(f"{type(error).__name__}: {error}")
    errors.put(failures)


def test_two_processes_writing_one_file_never_fail_and_readers_never_see_a_part(tmp_path: Path) -> None:
    path = tmp_path / "shared.txt"
    write_text_atomically(path, _content(9, 0))
    context = multiprocessing.get_context("fork")
    errors = context.Queue()
    writers = [context.Process(target=_write_many, args=(path, writer, errors)) for writer in (0, 1)]
    for process in writers:
        process.start()
    reads, torn = 0, []
    while any(process.is_alive() for process in writers):
        text = path.read_text()
        reads += 1
        if not _is_whole(text):
            torn.append(text[:40])
    failures = [failure for _ in writers for failure in errors.get(timeout=60)]
    for process in writers:
        process.join(timeout=60)
        assert process.exitcode == 0
    assert failures == [] and torn == []
    assert reads > 10  # the reads overlapped the writes
    assert _is_whole(path.read_text()) and [p.name for p in tmp_path.iterdir()] == ["shared.txt"]


def _write_past_the_limit(path: Path, results: multiprocessing.Queue) -> None:
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # so that a write past the limit raises EFBIG
    resource.setrlimit(resource.RLIMIT_FSIZE, (1_000, 1_000))
    try:
        write_text_atomically(path, "x" * 5_000)
    except OSError as error:
        results.put((error.errno, error.filename, str(error)))
    else:
        results.put(None)


def test_a_write_past_the_file_size_limit_names_the_file_and_leaves_the_old_one_and_no_temporary(
    tmp_path: Path,
) -> None:
    path = tmp_path / "record.json"
    path.write_text("old")
    context = multiprocessing.get_context("fork")
    results = context.Queue()
    child = context.Process(target=_write_past_the_limit, args=(path, results))
    child.start()
    outcome = results.get(timeout=60)
    child.join(timeout=60)
    assert outcome is not None, "the write past the limit did not fail"
    number, filename, message = outcome
    assert number == errno.EFBIG and filename == str(path) and message.endswith(f"File too large: '{path}'")
    assert path.read_text() == "old" and [p.name for p in tmp_path.iterdir()] == ["record.json"]


def test_a_block_that_fails_raises_naming_the_file_and_removes_its_temporary(tmp_path: Path) -> None:
    path = tmp_path / "best_model.zip"
    with pytest.raises(OSError) as caught, replacing_atomically(path) as temporary:
        temporary.write_bytes(b"partial")
        raise OSError(errno.ENOSPC, "No space left on device")
    assert caught.value.errno == errno.ENOSPC and caught.value.filename == str(path)
    assert list(tmp_path.iterdir()) == []


def test_the_temporary_keeps_the_suffix_and_the_file_gets_the_usual_mode(tmp_path: Path) -> None:
    path = tmp_path / "evaluations.npz"
    with replacing_atomically(path) as temporary:
        assert temporary.parent == tmp_path and temporary.name.startswith(".evaluations.")
        assert temporary.suffix == ".npz"
        temporary.write_bytes(b"data")
    assert path.read_bytes() == b"data"
    assert os.stat(path).st_mode & 0o777 == NEW_FILE_MODE


def test_copying_a_missing_file_names_it_and_leaves_nothing(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match=r"No such file or directory: '.*missing.zip'"):
        copy_atomically(tmp_path / "missing.zip", tmp_path / "policy.zip")
    assert list(tmp_path.iterdir()) == []
    (tmp_path / "best.zip").write_bytes(b"model")
    copy_atomically(tmp_path / "best.zip", tmp_path / "policy.zip")
    assert (tmp_path / "policy.zip").read_bytes() == b"model"
