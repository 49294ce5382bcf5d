"""The episodes CSV: one row per finished episode, appended as it ends, so a run can resume where it stopped."""

from __future__ import annotations

import csv
import os
from collections.abc import Iterable, Mapping
from dataclasses import asdict, fields
from pathlib import Path
from typing import Any

from agents.evaluation.episode import EpisodeRecord

CSV_FIELDS = [f.name for f in fields(EpisodeRecord)]


def append_record(path: Path, record: EpisodeRecord) -> None:
    """Append one row and flush it to disk, so an interrupted run loses at most the episode in flight."""
    path.parent.mkdir(parents=True, exist_ok=True)
    new_file = not path.exists() or path.stat().st_size == 0
    torn = False
    if not new_file:
        with path.open("rb") as existing:
            existing.seek(-1, os.SEEK_END)
            torn = existing.read(1) != b"\n"
    with path.open("a", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=CSV_FIELDS)
        if new_file:
            writer.writeheader()
        if torn:
            handle.write("\n")  # end a row cut off by an interruption; reading skips it
        writer.writerow(asdict(record))
        handle.flush()
        os.fsync(handle.fileno())


def read_records(path: Path) -> list[dict[str, Any]]:
    """Rows of an episodes CSV with typed values; a missing file gives no rows. A torn last line is skipped."""
    if not path.exists():
        return []
    types = {f.name: f.type for f in fields(EpisodeRecord)}
    rows = []
    with path.open(newline="") as handle:
        for raw in csv.DictReader(handle):
            if None in raw.values() or len(raw) != len(CSV_FIELDS):
                continue
            row: dict[str, Any] = {}
            for key, text in raw.items():
                kind = types[key]
                if kind in ("bool", bool):
                    row[key] = text == "True"
                elif kind in ("int", int):
                    row[key] = int(text)
                elif kind in ("float", float):
                    row[key] = float(text)
                else:
                    row[key] = text
            rows.append(row)
    return rows


def drop_agents(path: Path, agents: Iterable[str]) -> int:
    """Delete every row of ``agents`` from an episodes CSV, so a resumed run flies them again (after a policy
    is retrained, its old episodes no longer describe it). Other rows are kept byte for byte; the file is
    replaced atomically, so an interruption leaves either the old or the new file. Returns the rows deleted."""
    if not path.exists():
        return 0
    dropped = set(agents)
    with path.open(newline="") as handle:
        lines = handle.read().splitlines(keepends=True)
    if not lines:
        return 0
    kept = [lines[0]] + [line for line in lines[1:] if line.split(",", 1)[0] not in dropped]
    temporary = path.with_name(path.name + ".tmp")
    temporary.write_text("".join(kept))
    os.replace(temporary, path)
    return len(lines) - len(kept)


def completed_keys(rows: Iterable[Mapping[str, Any]]) -> set[tuple[str, str, float, int]]:
    """(agent, factor, level, seed) of finished episodes: what a resumed run skips."""
    return {(r["agent"], r["factor"], float(r["level"]), int(r["seed"])) for r in rows}
