"""The episodes CSV: one row per finished episode, appended as it ends, so a run can resume where it stopped.

Each row carries what defined its episode (env id, the full env settings, the agent's parameters and the
policy file's hash, :data:`IDENTITY_FIELDS`), so a resumed run only counts episodes flown with its own settings,
and its checksum (see :mod:`agents.analysis.csv_file`), so a torn row is flown again rather than misread.
Every value is checked by type on reading; a row that fails is skipped like a torn one. Files from before these
columns still read: their rows have None for the identity fields (unknown).
"""

from __future__ import annotations

import io
import numbers
import os
import sys
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any, Literal, cast

from agents.analysis.csv_file import (
    CHECKSUM_FIELD,
    LEGACY_FIELDS,
    ReadsPerFile,
    append_line,
    csv_header,
    csv_line,
    move_aside,
    parse_row,
    read_csv_content,
    repair_header,
    rewrite_locked,
    sealed_line,
)
from agents.analysis.earlier_rows import earlier_headers, exclusive_outcome, upgrade_row
from agents.analysis.episode_record import EpisodeRecord, EpisodeRow

RECORD_FIELDS = [f.name for f in fields(EpisodeRecord)]
CSV_FIELDS = [*RECORD_FIELDS, CHECKSUM_FIELD]
# A file written before one of the columns added since identities keeps its own columns when episodes are
# appended (the newer values are then unknown, None on reading), so resuming never re-flies
# (agents.analysis.earlier_rows). EARLIER_CSV_FIELDS[k]: the header of files from before earlier_rows.ADDED_FIELDS[k].
EARLIER_CSV_FIELDS = earlier_headers(CSV_FIELDS)
PREVIOUS_CSV_FIELDS = EARLIER_CSV_FIELDS[0]  # before the outlier share: the committed result CSVs
_READABLE_HEADERS = [CSV_FIELDS, *reversed(EARLIER_CSV_FIELDS), LEGACY_FIELDS]

# What a resumed run compares besides (agent, factor, level, seed). The record's code_version is left out on
# purpose: it changes with every commit, and comparing it would fly every episode again after any change.
IdentityField = Literal["env_id", "env_kwargs", "agent_params", "policy_sha256"]
IDENTITY_FIELDS: tuple[IdentityField, ...] = ("env_id", "env_kwargs", "agent_params", "policy_sha256")

_FIELD_TYPES = {f.name: f.type for f in fields(EpisodeRecord)}
_REQUIRED_TEXT = ("agent", "factor")


def overwrite_hint(out_names: str = "file") -> str:
    """The remedy of a command with ``--overwrite`` whose ``--out`` names a ``out_names`` (file or folder)."""
    return (
        f"write to another {out_names} (--out), or start a new one with --overwrite "
        "(the old file is moved to <name>.bak-<time>, nothing is deleted)"
    )


# How to get past episodes that cannot be resumed, for commands with --out and --overwrite. FRESH_FILE_HINT,
# the default, names no option, so no message suggests one that its command lacks.
OVERWRITE_HINT = overwrite_hint()
FRESH_FILE_HINT = "rename the file (nothing is lost) or write to another output folder, and run again"


@dataclass
class EpisodesCsv:
    """An episodes CSV as read: its typed rows, how many lines were skipped as torn or corrupt, and whether
    it predates episode identities (``legacy``: its rows cannot be told apart by settings). ``duplicates``
    counts rows dropped because an earlier row is the same episode (:func:`episode_identity`), as two runs
    writing one file at once could leave: each episode counts once."""

    path: Path
    rows: list[EpisodeRow]
    skipped: int = 0
    legacy: bool = False
    duplicates: int = 0


def append_record(path: Path, record: EpisodeRecord) -> bool:
    """Append one row (with its checksum) and flush it to disk, so an interrupted run loses at most the
    episode in flight; safe while other processes append to the same file. Returns False, appending nothing,
    when the file already holds the same episode (:func:`episode_identity`): another run wrote it first.

    Raises:
        ValueError: the file is not an episodes CSV of this format (a foreign or pre-identity header).
        OSError: the disk is full or the file cannot be written; the message names it.
    """
    path = Path(path)
    first_line = _first_line(path)
    columns = next((earlier for earlier in EARLIER_CSV_FIELDS if first_line == csv_line(earlier)), CSV_FIELDS)
    row = asdict(record)
    values = [str(row[name]) for name in columns if name != CHECKSUM_FIELD]
    identity = episode_identity(row)
    return append_line(
        path,
        csv_line(columns) + "\r\n",
        sealed_line(values),
        other_header_error=lambda: f"cannot add episodes to {path}: {_header_problem(path)}",
        already_there=lambda handle: identity in flown_episodes(path, handle),
    )


def _first_line(path: Path) -> str:
    """The file's first line without its line end ("" for a missing or empty file)."""
    try:
        with open(path, "rb") as handle:
            return handle.readline().rstrip(b"\r\n").decode("utf-8", "replace")
    except OSError:  # missing, or not a file: append_line says what is wrong
        return ""


def _header_problem(path: Path) -> str:
    header = read_csv_content(path, _READABLE_HEADERS).header  # raises for a foreign file
    if header == LEGACY_FIELDS:
        return predates_identities(path)
    return "its header is not this version's"


def predates_identities(path: Path, remedy: str = FRESH_FILE_HINT) -> str:
    """Why nothing can be resumed in or appended to a pre-identity CSV, and what to do instead (``remedy``:
    what the command at hand offers, :data:`OVERWRITE_HINT` where it has ``--overwrite``)."""
    return (
        f"{path} predates episode identities (no env_id, env_kwargs, agent_params or policy_sha256 "
        "columns), so its episodes cannot be matched to these settings; reports can still be built from it "
        f"(flownav sweep --report-only). To fly episodes, {remedy}"
    )


def read_episodes(path: Path) -> EpisodesCsv:
    """The episodes CSV at ``path`` with typed values; a missing file gives no rows. Torn rows and rows with
    a value of the wrong type (not True/False, not a number, an empty agent or factor) are skipped.

    Raises:
        ValueError: ``path`` is a directory, binary, or another kind of CSV; the message names it.
    """
    path = Path(path)
    content = read_csv_content(path, _READABLE_HEADERS)
    episodes = EpisodesCsv(path, [], content.skipped, legacy=content.header == LEGACY_FIELDS)
    seen: set[tuple] = set()
    for raw in content.rows:
        row = _typed(raw)
        if row is None:
            episodes.skipped += 1
        elif (identity := episode_identity(row)) in seen:
            episodes.duplicates += 1
        else:
            seen.add(identity)
            episodes.rows.append(row)
    if episodes.duplicates:
        READ_NOTICES.say_once(
            f"{path}: {episodes.duplicates} duplicate rows dropped (the same episode with the same settings "
            "written twice, as runs writing one file at once could); each episode counts once"
        )
    return episodes


def repair_episodes_header(path: Path) -> str | None:
    """Give an episodes CSV whose header is damaged but whose rows pass their checksums a correct header
    (:func:`~agents.analysis.csv_file.repair_header`), so its episodes are not stranded; returns the one line
    that says what was done, or None when there was nothing to repair."""
    path = Path(path)
    repair = repair_header(path, _READABLE_HEADERS)
    if repair is None:
        return None
    return (
        f"{path} had a damaged header: its {repair.kept} checksummed rows now sit under a correct header in a "
        f"new {path.name} ({repair.dropped} damaged rows left out); the damaged file is kept as {repair.backup}"
    )


class Notices:
    """Messages printed to stderr once per process: a file is read several times a run, and its problems are
    said the first time."""

    def __init__(self) -> None:
        self.said: set[str] = set()

    def say_once(self, message: str) -> None:
        """Print ``message`` unless this object printed it before."""
        if message not in self.said:
            self.said.add(message)
            print(message, file=sys.stderr)


# What this process has said about the episodes CSVs it read.
READ_NOTICES = Notices()


def read_records(path: Path) -> list[EpisodeRow]:
    """Rows of an episodes CSV with typed values (see :func:`read_episodes`)."""
    return read_episodes(path).rows


def _typed(raw: Mapping[str, str]) -> EpisodeRow | None:
    row: dict[str, Any] = {}
    for name, text in upgrade_row(raw, RECORD_FIELDS).items():
        kind = _FIELD_TYPES[name]
        if text is None:  # a column the file's format predates: unknown
            row[name] = None
            continue
        if kind in ("bool", bool):
            if text not in ("True", "False"):
                return None
            row[name] = text == "True"
        elif kind in ("int", int, "float", float):
            try:
                row[name] = int(text) if kind in ("int", int) else float(text)
            except ValueError:
                return None
        else:
            if not text and name in _REQUIRED_TEXT:
                return None
            row[name] = text
    return exclusive_outcome(cast(EpisodeRow, row))  # every field set above, each checked by its type


def row_identity(row: Mapping[str, object]) -> tuple[str, ...] | None:
    """The row's :data:`IDENTITY_FIELDS` values; None where the file predates them (unknown)."""
    known = [str(value) for name in IDENTITY_FIELDS if (value := row.get(name)) is not None]
    return tuple(known) if len(known) == len(IDENTITY_FIELDS) else None


def episode_key(row: Mapping[str, object]) -> tuple[str, str, float, int]:
    """(agent, factor, level, seed): which episode of a run a row or task is.

    Raises:
        ValueError: a level that is not a number or a seed that is not an integer (as numbers or their text).
    """
    level = row["level"]
    if not isinstance(level, numbers.Real | str):
        raise ValueError(f"an episode's level is a number, got {level!r}")
    return (str(row["agent"]), str(row["factor"]), float(level), layout_seed(row))


def layout_seed(row: Mapping[str, object]) -> int:
    """The layout seed a row, record or task was flown from.

    Raises:
        ValueError: a seed that is not an integer (as a number or its text).
    """
    seed = row["seed"]
    if not isinstance(seed, numbers.Integral | str):
        raise ValueError(f"an episode's seed is an integer, got {seed!r}")
    return int(seed)


def suite_version_of(row: Mapping[str, object]) -> str:
    """The suite version a row, record or task was flown under; "" outside the suite, or in files from before
    the column (their episodes are not the suite's)."""
    return str(row.get("suite_version") or "")


def episode_identity(row: Mapping[str, object]) -> tuple:
    """Everything that makes a row the episode it is: its :func:`episode_key`, :func:`row_identity` and
    suite version (an episode of another suite version is another episode). Works on typed rows, on a
    line's text values and on a record's fields alike."""
    return (*episode_key(row), row_identity(row), suite_version_of(row))


@dataclass
class _EpisodeIndex:
    """The episodes of one CSV as far as it has been read: reading resumes at ``offset`` while the file is
    the same (``inode``) and has not shrunk, so checking before each episode costs only the new rows."""

    inode: int = -1
    offset: int = 0
    header: list[str] | None = None
    flown: set[tuple] = field(default_factory=set)

    def update(self, handle: io.FileIO) -> None:
        stat = os.fstat(handle.fileno())
        if stat.st_ino != self.inode or stat.st_size < self.offset:
            self.inode, self.offset, self.header, self.flown = stat.st_ino, 0, None, set()
        data = os.pread(handle.fileno(), stat.st_size - self.offset, self.offset)
        whole = data[: data.rfind(b"\n") + 1]  # a last row still being written is read next time
        self.offset += len(whole)
        for line in whole.split(b"\n"):
            line = line.rstrip(b"\r")
            if not line:
                continue
            if self.header is None:
                self.header = csv_header(line)
            elif (raw := parse_row(line, self.header)) is not None:
                self.flown.add(episode_identity(raw))


# This process's index of each episodes CSV it appends to or claims in.
EPISODE_INDEXES = ReadsPerFile(_EpisodeIndex)


def flown_episodes(path: Path, handle: io.FileIO) -> set[tuple]:
    """The :func:`episode_identity` of every whole row in the CSV at ``path``, whose lock the caller holds
    (``handle``, from :func:`~agents.analysis.csv_file.locked`); rows read on an earlier call are not read
    again."""
    index = EPISODE_INDEXES.of(path)
    index.update(handle)
    return index.flown


def drop_agents(path: Path, agents: Iterable[str]) -> int:
    """Delete every row of ``agents`` from an episodes CSV, so a resumed run flies them again (after a policy
    is retrained, its old episodes no longer describe it). Other rows are kept byte for byte; the file is
    replaced atomically under its lock, so an interruption leaves either the old or the new file and no
    concurrent append is lost. Returns the rows deleted.

    Raises:
        ValueError: ``path`` is not an episodes CSV.
    """
    path = Path(path)
    if not path.exists():
        return 0
    read_episodes(path)  # refuses a file that is not an episodes CSV before rewriting it
    dropped = set(agents)
    return rewrite_locked(path, lambda line: line.split(",", 1)[0] not in dropped)


def start_new_file(path: Path) -> Path | None:
    """For ``--overwrite``: move the episodes CSV at ``path`` to ``<name>.bak-<UTC time>`` so the next run
    starts a new file there; returns where it went (None if there was none). Nothing is deleted."""
    return move_aside(Path(path))
