"""Small writers every report shares: Markdown tables, CSV files and the report's time stamp."""

from __future__ import annotations

import csv
import datetime
from collections.abc import Mapping, Sequence
from pathlib import Path


def today() -> str:
    """The date and time of the run, UTC, for the report header."""
    return datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")


def write_csv(path: Path, rows: Sequence[Mapping[str, object]]) -> None:
    """Write dict rows (all with the same keys) to a CSV file."""
    with path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def markdown_cell(text: object) -> str:
    """``text`` as one Markdown table cell that cannot end its row or add one: line breaks become spaces, ``|``
    is escaped and backticks (which would end a code span around it) become quotes."""
    return " ".join(str(text).split()).replace("|", "\\|").replace("`", "'")


def markdown_table(header: Sequence[str], rows: Sequence[Sequence[object]]) -> str:
    """A GitHub Markdown table; cells are written with ``str``."""
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(str(cell) for cell in row) + " |" for row in rows]
    return "\n".join(lines)
