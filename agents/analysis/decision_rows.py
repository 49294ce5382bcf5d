"""The decision log's choices per agent, as a CSV beside the suite: which logged choice shaped which agent, when,
and the test rows already committed then. ``flownav decision-log`` writes it (from ``configs/decisions.yaml`` and
the repository's history); ``suite.md`` reads it, so the suite page shows per agent what was visible when its
recipe was chosen without reading git itself."""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path
from typing import TypedDict

DECISION_CSV = "decision_log.csv"
COLUMNS = ("agent", "decision", "commit", "date", "visible")


class AgentDecision(TypedDict):
    """One logged choice that governs ``agent``: its id, commit and date, and the test rows committed by then
    (``visible``: "agent count; ..." or "none")."""

    agent: str
    decision: str
    commit: str
    date: str
    visible: str


def write_decision_rows(path: Path, rows: Sequence[AgentDecision]) -> None:
    """Write ``rows`` to the CSV at ``path`` (replacing it)."""
    with Path(path).open("w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=COLUMNS)
        writer.writeheader()
        writer.writerows(rows)


def read_decision_rows(path: Path) -> dict[str, list[AgentDecision]]:
    """The CSV at ``path`` by agent, in file order (empty where there is no file).

    Raises:
        ValueError: a file whose header is not :data:`COLUMNS` (the message names the file).
    """
    if not Path(path).is_file():
        return {}
    with Path(path).open(newline="", encoding="utf-8") as handle:
        reader = csv.DictReader(handle)
        if tuple(reader.fieldnames or ()) != COLUMNS:
            raise ValueError(f"{path}: expected the columns {', '.join(COLUMNS)}, got {reader.fieldnames}")
        found: dict[str, list[AgentDecision]] = {}
        for row in reader:
            entry = AgentDecision(
                agent=row["agent"],
                decision=row["decision"],
                commit=row["commit"],
                date=row["date"],
                visible=row["visible"],
            )
            found.setdefault(entry["agent"], []).append(entry)
    return found
