"""Output folders checked before the work starts, and write errors that name their file.

A command that trains or evaluates for an hour should not find out at its first save that its output folder is
read-only or its disk full: :func:`check_writable_folder` tries a write up front. Errors from writes deep inside
other libraries (a full disk, a file-size limit) often carry no file name; :func:`naming_file` gives them one,
so the command can report them in one line. Files that readers may meet half-written are written through
:func:`replacing_atomically`, the one atomic writer.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from pathlib import Path

PROBE_NAME = ".flownav_write_probe"


def check_writable_folder(path: Path | str, option: str | None = None) -> None:
    """Create the folder ``path`` if needed, then write and delete a small probe file in it; the folders the
    check created are removed again, so that it leaves nothing behind.

    Args:
        path: the output folder.
        option: the command-line option that chose the folder (``--runs-dir``), named in the message.

    Raises:
        ValueError: the folder cannot be created or written (read-only file system, no space left, a file in
            its place, no permission); one line naming the folder and the reason.
    """
    folder = Path(path)
    advice = f": pick another {option}" if option else ""
    if folder.exists() and not folder.is_dir():
        raise ValueError(f"output folder {folder} is a file, not a folder{advice}")
    probe = folder / f"{PROBE_NAME}.{os.getpid()}"
    created = [p for p in (folder, *folder.parents) if not p.exists()]  # deepest first
    try:
        folder.mkdir(parents=True, exist_ok=True)
        # Closing flushes the write: a full disk may only refuse it then.
        with probe.open("wb") as file:
            file.write(b"flownav checks that this folder takes files\n")
    except OSError as error:
        reason = error.strerror or type(error).__name__
        raise ValueError(f"cannot write to the output folder {folder} ({reason}){advice}") from None
    finally:
        # A removal that fails (nothing was written, or the folder refuses even that) changes nothing.
        with suppress(OSError):
            probe.unlink(missing_ok=True)
            for made in created:
                made.rmdir()


def named_os_error(error: OSError, path: Path | str) -> OSError:
    """``error`` when it names a file; otherwise the same error (errno and message) naming ``path``."""
    if error.filename is not None:
        return error
    named = OSError(error.errno, error.strerror or str(error), str(path))
    named.__traceback__ = error.__traceback__
    return named


@contextmanager
def naming_file(path: Path | str) -> Iterator[None]:
    """Within the block, an ``OSError`` without a file name (``write`` on a full disk raises one) is raised
    again naming ``path``, without the original chained to it: one error, one line.

    Raises:
        OSError: from the block, naming a file.
    """
    try:
        yield
    except OSError as error:
        named = named_os_error(error, path)
        if named is error:
            raise
        raise named from None


def _file_mode() -> int:
    """The mode a newly created file gets under this process's umask (``mkstemp`` would give 0600)."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


NEW_FILE_MODE = _file_mode()


@contextmanager
def replacing_atomically(path: Path | str) -> Iterator[Path]:
    """Yield a new temporary file beside ``path`` for the block to write; when the block ends, the file is
    flushed to disk and renamed to ``path``. Readers see the old file or the whole new one, never a part.

    The temporary's name is unique (``.<stem>.<random><suffix>``, the suffix kept for writers that go by it:
    ``np.savez``, ``model.save``, ``savefig``), so processes writing the same ``path`` at once never write into
    or rename each other's file: the last rename wins, whole.

    Raises:
        OSError: the block or the rename failed; it names ``path``, and the temporary file is removed.
    """
    path = Path(path)
    with naming_file(path):
        descriptor, name = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=path.suffix, dir=path.parent)
        temporary = Path(name)
        try:
            os.fchmod(descriptor, NEW_FILE_MODE)
            os.close(descriptor)
            descriptor = -1
            yield temporary
            # Renamed before its data reach the disk, a crash could leave an empty file under the old name.
            with temporary.open("rb") as written:
                os.fsync(written.fileno())
            os.replace(temporary, path)
        except BaseException:
            with suppress(OSError):  # a failed cleanup must not hide why the write failed
                if descriptor >= 0:
                    os.close(descriptor)
                temporary.unlink(missing_ok=True)
            raise


def write_text_atomically(path: Path | str, text: str) -> None:
    """Write ``text`` to ``path`` through :func:`replacing_atomically`.

    Raises:
        OSError: the write failed; it names ``path``, and the temporary file is removed.
    """
    with replacing_atomically(path) as temporary:
        temporary.write_text(text)


def copy_atomically(source: Path | str, path: Path | str) -> None:
    """Copy the file ``source`` to ``path`` through :func:`replacing_atomically`.

    Raises:
        OSError: the copy failed; it names ``path`` (or ``source``, when that cannot be read), and the
            temporary file is removed.
    """
    with replacing_atomically(path) as temporary:
        shutil.copyfile(source, temporary)
