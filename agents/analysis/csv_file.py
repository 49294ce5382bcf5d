"""The episodes CSV as bytes on disk: one header, rows appended under a lock, each row sealed by a checksum.

An interrupted run leaves at most one torn row behind, and several processes may append to one file at once.
So every row ends with ``row_crc``, the CRC32 of the rest of its line: a row cut anywhere, even inside its
last field, fails the check and is skipped (its episode is flown again). Appends hold an exclusive
``flock`` on the file, so the header is written exactly once and rows never interleave. Files written before
these columns existed (:data:`LEGACY_FIELDS`) are still read; their rows carry no checksum.
"""

from __future__ import annotations

import csv
import datetime
import fcntl
import io
import os
import zlib
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Generic, TypeVar

CHECKSUM_FIELD = "row_crc"

# The columns of episodes CSVs written before episodes carried their identity.
LEGACY_FIELDS = [
    "agent",
    "factor",
    "level",
    "seed",
    "collision",
    "success",
    "out_of_bounds",
    "truncated",
    "progress_m",
    "time_s",
    "steps",
    "min_clearance_m",
    "path_length_m",
    "mean_points_valid",
    "median_depth_error",
    "episode_return",
]

LINE_END = "\r\n"  # what csv.writer ends lines with, kept so old and new rows look alike

Read = TypeVar("Read")


class ReadsPerFile(Generic[Read]):
    """A process's reads of files it reads again and again, one per file (by resolved path), each made by
    ``make`` on first use: a read resumes where the last one stopped, so each check costs only the new lines."""

    def __init__(self, make: Callable[[], Read]) -> None:
        self.make = make
        self.reads: dict[str, Read] = {}

    def of(self, path: Path) -> Read:
        """The read of the file at ``path``, new on the first call for it."""
        key = str(Path(path).resolve())
        if key not in self.reads:
            self.reads[key] = self.make()
        return self.reads[key]


def csv_line(values: list[str]) -> str:
    """``values`` as one CSV line without its line end (quoted as csv.writer quotes)."""
    buffer = io.StringIO()
    csv.writer(buffer, lineterminator="").writerow(values)
    return buffer.getvalue()


def row_checksum(values: list[str]) -> str:
    """CRC32 of the row's line as written, hex: what ``row_crc`` holds for ``values``."""
    return f"{zlib.crc32(csv_line(values).encode()):08x}"


def sealed_line(values: list[str]) -> str:
    """The line to append for a row: its values, then their checksum, then the line end."""
    return csv_line([*values, row_checksum(values)]) + LINE_END


@dataclass
class CsvContent:
    """What an episodes CSV holds: its header (empty for a missing or empty file), the rows that parsed
    whole (as text, keyed by column), and how many lines were skipped as torn or corrupt."""

    header: list[str] = field(default_factory=list)
    rows: list[dict[str, str]] = field(default_factory=list)
    skipped: int = 0


def check_is_file_target(path: Path) -> None:
    """Refuse a path that cannot be an episodes CSV before anything is read or written there.

    Raises:
        ValueError: ``path`` is a directory, or a folder on its way is a file.
    """
    if path.is_dir():
        raise ValueError(f"{path} is a directory, not an episodes CSV: give the path of a .csv file")
    for parent in path.parents:
        if parent.exists() and not parent.is_dir():
            raise ValueError(f"cannot write the episodes CSV {path}: {parent} is a file, not a folder")


def read_csv_content(path: Path, expected_headers: list[list[str]]) -> CsvContent:
    """The header and whole rows of the CSV at ``path``; a missing or empty file has neither.

    Each physical line is decoded and parsed on its own (no field holds a line break), so a torn row or a
    flipped byte costs that row alone (skipped, its episode flown again), never the rows after it. A row is
    kept if it is UTF-8, has the header's field count and, where the header ends with ``row_crc``, its
    checksum matches.

    Raises:
        ValueError: ``path`` is a directory, or its first line is not UTF-8 text or none of
            ``expected_headers``; the message names the file.
    """
    check_is_file_target(path)
    if not path.exists():
        return CsvContent()
    lines = [line.rstrip(b"\r") for line in path.read_bytes().split(b"\n")]
    lines = [line for line in lines if line]
    if not lines:
        return CsvContent()
    try:
        first = lines[0].decode("utf-8")
    except UnicodeDecodeError as error:
        raise ValueError(
            f"{path} is not an episodes CSV (its first line is not UTF-8 text: {error.reason} at byte "
            f"{error.start}); give another file"
        ) from None
    header = _parse_line(first)
    if header not in expected_headers:
        raise ValueError(
            f"{path} is not a FlowNav episodes CSV: its header starts {first[:60]!r}, expected "
            f"'{','.join(LEGACY_FIELDS[:4])},...'; give another file"
        )
    content = CsvContent(header=header)
    for line in lines[1:]:
        row = parse_row(line, header)
        if row is None:
            content.skipped += 1
        else:
            content.rows.append(row)
    return content


def parse_row(line: bytes, header: list[str]) -> dict[str, str] | None:
    """One line of the CSV (without its line end) keyed by ``header``; None for a torn or corrupt line: not
    UTF-8, a field count other than the header's or, where the header ends with ``row_crc``, a checksum that
    does not match."""
    try:
        values = _parse_line(line.decode("utf-8"))
    except UnicodeDecodeError:
        return None
    if values is None or len(values) != len(header):
        return None
    if header[-1] == CHECKSUM_FIELD and values[-1] != row_checksum(values[:-1]):
        return None
    return dict(zip(header, values, strict=True))


def csv_header(line: bytes) -> list[str]:
    """The column names on a CSV's first line (without its line end); [] when it is not a CSV line."""
    return _parse_line(line.decode("utf-8", "replace")) or []


def _parse_line(line: str) -> list[str] | None:
    try:
        return next(csv.reader([line], strict=True))
    except (csv.Error, StopIteration):
        return None


@contextmanager
def locked(path: Path) -> Iterator[io.FileIO]:
    """The file at ``path`` (created empty if missing), open unbuffered for reading and appending under an
    exclusive ``flock``. If another process replaced the file while this one waited, the new file is locked
    instead, so nothing is appended to a file no longer at ``path``. Unbuffered, so a failed write (a full
    disk) raises once, where it happens, and closing has nothing left to flush."""
    check_is_file_target(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    while True:
        handle = path.open("a+b", buffering=0)
        try:
            fcntl.flock(handle.fileno(), fcntl.LOCK_EX)
            if path.exists() and os.stat(path).st_ino == os.fstat(handle.fileno()).st_ino:
                yield handle
                return
        finally:
            handle.close()  # closing releases the lock


def append_line(
    path: Path,
    header_line: str,
    line: str,
    other_header_error: Callable[[], str],
    already_there: Callable[[io.FileIO], bool] | None = None,
) -> bool:
    """Append ``line`` to the CSV at ``path`` under its lock, writing ``header_line`` first if the file is new
    or empty, and ending a torn last row first so it stays a line of its own (reading skips it). Flushed to
    disk before the lock is released, so an interrupted run loses at most the episode in flight.

    Args:
        already_there: called with the locked file once its header is checked; when it says the row is
            there already (another run wrote the same episode), nothing is appended.

    Returns:
        Whether the line was appended.

    Raises:
        ValueError: the file holds another header; ``other_header_error()`` says why that is refused.
        OSError: the write failed (a full disk, a file-size limit); the message names the file. What was
            written before stays; a partly written row is skipped on reading.
    """
    header = header_line.encode()
    with locked(path) as handle:
        size = os.fstat(handle.fileno()).st_size
        prefix = b""
        if size == 0:
            prefix = header
        else:
            first = os.pread(handle.fileno(), len(header) + 1, 0).partition(b"\n")[0]
            if first.rstrip(b"\r") != header.rstrip(b"\r\n"):
                raise ValueError(other_header_error())
            if already_there is not None and already_there(handle):
                return False
            if os.pread(handle.fileno(), 1, size - 1) != b"\n":
                prefix = b"\n"
        try:
            _write_all(handle.fileno(), prefix + line.encode())  # a reader sees whole rows or a torn last one
            os.fsync(handle.fileno())
        except OSError as error:
            raise OSError(error.errno, f"cannot add an episode: {error.strerror}", str(path)) from None
    return True


def _write_all(descriptor: int, data: bytes) -> None:
    view = memoryview(data)
    while view:
        view = view[os.write(descriptor, view) :]


def rewrite_locked(path: Path, keep_line: Callable[[str], bool]) -> int:
    """Replace the file at ``path`` atomically by its header and the lines ``keep_line(line)`` accepts,
    holding its lock meanwhile so no append is lost to the old file. Returns the lines dropped."""
    with locked(path) as handle:
        handle.seek(0)
        # surrogateescape: a corrupt byte survives the round trip, so kept lines stay byte for byte
        lines = handle.read().decode("utf-8", "surrogateescape").splitlines(keepends=True)
        if not lines:
            return 0
        kept = [lines[0]] + [line for line in lines[1:] if keep_line(line)]
        temporary = path.with_name(path.name + ".tmp")
        temporary.write_bytes("".join(kept).encode("utf-8", "surrogateescape"))
        os.replace(temporary, path)
        return len(lines) - len(kept)


def move_aside(path: Path) -> Path | None:
    """Rename the file at ``path`` to ``<name>.bak-<UTC time>`` (never over an existing file), so a new
    file can start there without deleting anything. Returns the new name; None if there was no file."""
    check_is_file_target(path)
    if not path.exists():
        return None
    backup = _link_backup(path)
    os.unlink(path)
    return backup


def _link_backup(path: Path) -> Path:
    """A second name for the file at ``path``, ``<name>.bak-<UTC time>`` (never over an existing file)."""
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y%m%dT%H%M%SZ")
    for attempt in range(1000):
        backup = path.with_name(f"{path.name}.bak-{stamp}" + (f"-{attempt}" if attempt else ""))
        try:
            os.link(path, backup)  # fails if the name is taken: nothing is overwritten
        except FileExistsError:
            continue
        return backup
    raise ValueError(f"cannot move {path} aside: too many backups named {path.name}.bak-{stamp}*")


@dataclass(frozen=True)
class HeaderRepair:
    """A CSV whose header was damaged, rewritten: its checksummed rows (``kept``) under a correct header, the
    lines that failed (``dropped``) left out, the damaged file kept as ``backup``."""

    backup: Path
    kept: int
    dropped: int


def repair_header(path: Path, expected_headers: list[list[str]]) -> HeaderRepair | None:
    """Give the CSV at ``path`` a correct header when its own is damaged (a flipped bit) but its rows still
    pass their checksums under one of ``expected_headers``: those rows go to a new file at ``path``, byte for
    byte, and the damaged file is kept as ``<name>.bak-<time>``. Held under the file's lock, and the new file
    replaces the old atomically, so no concurrent append is lost.

    Returns:
        What was done; None when the header is intact, the file is missing or empty, or no row checks
        under any checksummed header (then it is another kind of file, which reading refuses).
    """
    check_is_file_target(path)
    if not path.is_file():
        return None
    with locked(path) as handle:
        handle.seek(0)
        lines = [line.rstrip(b"\r") for line in handle.read().split(b"\n")]
        lines = [line for line in lines if line]
        if not lines or csv_header(lines[0]) in expected_headers:
            return None
        best: list[str] = []
        kept: list[bytes] = []
        for header in expected_headers:
            if header[-1] != CHECKSUM_FIELD:
                continue
            rows = [line for line in lines if parse_row(line, header) is not None]
            if len(rows) > len(kept):
                best, kept = header, rows
        if not kept:
            return None
        temporary = path.with_name(path.name + ".tmp")
        temporary.write_bytes(b"".join(line + LINE_END.encode() for line in [csv_line(best).encode(), *kept]))
        backup = _link_backup(path)
        os.replace(temporary, path)
    # The first line was the damaged header unless it was itself a row (a file whose header is gone).
    header_lines = 0 if parse_row(lines[0], best) is not None else 1
    return HeaderRepair(backup, len(kept), len(lines) - header_lines - len(kept))
