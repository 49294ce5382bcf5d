"""The re-flights of published suite episodes, as ``suite_reflight.csv`` keeps them: each episode flown again on a
CPU, the numbers that came out otherwise and whether it ended the same way; and their summary per agent and CPU,
which ``suite.md`` words (flown by :mod:`agents.evaluation.reflight`)."""

from __future__ import annotations

import csv
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

REFLIGHT_CSV = "suite_reflight.csv"
COLUMNS = ("agent", "run", "tier", "seed", "cpu", "code_version", "differs", "same_outcome")


@dataclass(frozen=True)
class Reflight:
    """One published episode flown again: its agent, run, tier and layout, the CPU it re-flew on, the code version
    its row was flown by, the measured numbers that came out otherwise ("" when none did) and whether it ended the
    same way."""

    agent: str
    run: str
    tier: str
    seed: int
    cpu: str
    code_version: str
    differs: str
    same_outcome: bool

    @property
    def identical(self) -> bool:
        """Whether every measured number came out equal to the last bit."""
        return not self.differs


def read_reflights(path: Path) -> list[Reflight]:
    """The re-flights recorded at ``path`` (none where there is no file)."""
    if not Path(path).is_file():
        return []
    with Path(path).open(newline="") as handle:
        return [
            Reflight(
                row["agent"],
                row["run"],
                row["tier"],
                int(row["seed"]),
                row["cpu"],
                row["code_version"],
                row["differs"],
                row["same_outcome"] == "True",
            )
            for row in csv.DictReader(handle)
        ]


def write_reflights(path: Path, rows: Sequence[Reflight]) -> None:
    """``rows`` added to those at ``path``; a re-flight of the same run, tier, layout and CPU replaces the old."""
    kept = {(row.run, row.tier, row.seed, row.cpu): row for row in [*read_reflights(path), *rows]}
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(COLUMNS)
        for row in sorted(kept.values(), key=lambda row: (row.agent, row.cpu, row.tier, row.seed, row.run)):
            writer.writerow([getattr(row, column) for column in COLUMNS])


@dataclass(frozen=True)
class ReflightSummary:
    """An agent's re-flights on one CPU: how many, how many identical, how many with the same outcome, and the
    measured numbers that differed with how often (``path_length_m: 3``), and the code versions its rows were flown
    by."""

    agent: str
    cpu: str
    flown: int
    identical: int
    same_outcome: int
    differed: str = ""
    code_versions: str = ""


def summarise_reflights(rows: Sequence[Reflight]) -> list[ReflightSummary]:
    """Per agent and CPU, in the order first met."""
    groups: dict[tuple[str, str], list[Reflight]] = {}
    for row in rows:
        groups.setdefault((row.agent, row.cpu), []).append(row)
    return [
        ReflightSummary(
            agent,
            cpu,
            len(found),
            sum(row.identical for row in found),
            sum(row.same_outcome for row in found),
            _differed(found),
            "; ".join(sorted({_short_version(row.code_version) for row in found})),
        )
        for (agent, cpu), found in groups.items()
    ]


def _differed(rows: Sequence[Reflight]) -> str:
    counts: dict[str, int] = {}
    for row in rows:
        for name in filter(None, row.differs.split(",")):
            counts[name] = counts.get(name, 0) + 1
    return ", ".join(f"{name}: {count}" for name, count in counts.items())


def _short_version(code_version: str) -> str:
    """``commit `abc1234` with uncommitted changes in ...`` as ``abc1234 + uncommitted changes``."""
    commit = code_version.partition("`")[2].partition("`")[0] or code_version or "unknown"
    return f"{commit} + uncommitted changes" if "uncommitted" in code_version else commit
