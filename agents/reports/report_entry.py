"""One entry of the registry of ``results/``'s Markdown reports (:mod:`agents.reports.report_registry`): what a
report is built from and how it is rebuilt, or why it is not."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Report:
    """One Markdown file of ``results/``, or one outside it with a generated block (the README).

    Attributes:
        path: the report, relative to ``results/`` (``ablation/speed_1.5/ablation.md``); a page of the repository
            outside ``results/`` climbs out of it (``../README.md``, whose results block is generated).
        name: what ``flownav reports --only`` calls it; empty for a report that is not regenerated.
        command: the stand-alone command that rebuilds it from the committed data (what the report names).
        inputs: glob patterns, relative to ``results/``, of the committed data it is built from; each must
            match a file, or the report is skipped.
        write: rebuilds the report (and its figures and tables) into the folder given, reading ``inputs``
            there when ``staged``; None: not regenerated, ``reason`` says why.
        staged: the writer reads its inputs from its own output folder, so they are copied there first.
        reason: one line, why a report is not regenerated.
    """

    path: str
    name: str = ""
    command: str = ""
    inputs: tuple[str, ...] = ()
    write: Callable[[Report, Path], object] | None = None
    staged: bool = True
    reason: str = ""

    @property
    def regenerated(self) -> bool:
        return self.write is not None


def not_regenerated(reason: str, *paths: str) -> tuple[Report, ...]:
    """A report per path, each not regenerated for ``reason``."""
    return tuple(Report(path, reason=reason) for path in paths)
