"""Every Markdown report in ``results/``, and the README's generated results block, and how to write the
machine-written ones again from the committed data without flying anything (``flownav reports``).

A report's numbers should be what the current code makes of the committed episodes: when a statistic changes
(a bootstrap interval, a table's layout), a report written before the change silently disagrees with the code
that claims to produce it. :data:`~agents.reports.report_registry.REPORTS` lists every ``results/**/*.md`` and
the README (``../README.md``): each machine-written report with a report-only path names its inputs and the
writer call that rebuilds it, in-process; every other one (prose, measurements of a machine's speed, stale
archives) says in one line why it is not regenerated. :func:`regenerate` writes the reports into any folder with
the layout of ``results/`` (:func:`written_at`), and :func:`differences` compares one with the committed file,
ignoring only the lines that record when, where and with which commit it was written (:func:`comparable_text`).
"""

from __future__ import annotations

import difflib
import filecmp
import shutil
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from agents.common.locations import RESULTS_DIR
from agents.reports.report_registry import REPORTS, Report

# Lines of a report's preamble that record how it was made, not what it says: every writer but the sweep's puts
# the date, command, commit and machine on one "Generated ..." line; the sweep's header
# (agents/pages/sweep_report.write_report) gives the commit, the machine and the wall time lines of their own.
PROVENANCE_PREFIXES = (
    "Generated ",
    "Code when this report was written: ",
    "Hardware: ",
    "Wall time of the last invocation: ",
    "Rebuilt with `--report-only` from the episodes flown so far",
)
# The preamble ends where the report's content starts: its first section, code block or table.
CONTENT_STARTS = ("## ", "```", "|")
# Where a page outside results/ (``../README.md``) is written in a folder that is not results/ itself: the
# layout of results/ has no place above its top, and a scratch folder's parent is not the repository.
OUTSIDE_RESULTS = "outside_results"


@dataclass(frozen=True)
class Outcome:
    """What :func:`regenerate` did with one report: where it wrote it (None: skipped, ``skipped`` says why)
    and how long the writer took."""

    report: Report
    written: Path | None
    seconds: float = 0.0
    skipped: str = ""


def report_names() -> list[str]:
    """The names ``--only`` takes: every regenerated report's, in registry order."""
    return [report.name for report in REPORTS if report.regenerated]


def select_reports(names: Sequence[str] | None = None) -> list[Report]:
    """The regenerated reports called ``names`` (all of them for None), in registry order.

    Raises:
        ValueError: a name no regenerated report has; the message lists the names there are.
    """
    allowed = report_names()
    for name in names or ():
        if name not in allowed:
            raise ValueError(
                f"--only: no regenerated report is called {name!r} (one of: {', '.join(allowed)})"
            )
    wanted = set(names) if names is not None else set(allowed)
    return [report for report in REPORTS if report.regenerated and report.name in wanted]


def missing_inputs(report: Report) -> str:
    """Why ``report`` cannot be regenerated here: the inputs that match no file under ``results/``, as
    "no results/x.csv (its data is not committed)"; empty when every input is there."""
    missing = [f"results/{pattern}" for pattern in report.inputs if not any(RESULTS_DIR.glob(pattern))]
    return f"no {', '.join(missing)} (its data is not committed)" if missing else ""


def _stage_inputs(report: Report, out: Path) -> None:
    """Copy ``report``'s committed inputs to the same places under ``out`` (nothing when ``out`` is
    ``results/``). Copies, not links: a writer that appended to a linked CSV would change the committed one.

    Raises:
        ValueError: ``out`` already holds a different file at an input's place (say, the ``results/`` of another
            checkout than the installed one, with episodes not yet committed): it is left alone, never replaced.
    """
    for pattern in report.inputs:
        for source in sorted(RESULTS_DIR.glob(pattern)):
            target = out / source.relative_to(RESULTS_DIR)
            if target.exists() and (target.samefile(source) or filecmp.cmp(source, target, shallow=False)):
                continue
            if target.exists():
                raise ValueError(
                    f"{target} differs from the committed {source} it would be replaced by: regenerate into "
                    f"a fresh --out, or into results/ of the checkout flownav runs from ({RESULTS_DIR.parent})"
                )
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(source, target)


def regenerate(out: Path, names: Sequence[str] | None = None) -> list[Outcome]:
    """Write the reports called ``names`` (every regenerated one for None) into ``out``, each at its path
    relative to ``results/``, from the data committed in ``results/``; flies nothing. A report whose inputs
    are not all there is skipped and says so. ``results/`` itself is written only when ``out`` is it.

    Raises:
        ValueError: an unknown name (before anything is written), or an unwritable ``out``.
    """
    reports = select_reports(names)
    out = Path(out).resolve()
    outcomes = []
    for report in reports:
        missing = missing_inputs(report)
        if missing:
            outcomes.append(Outcome(report, None, skipped=missing))
            continue
        written = written_at(report, out)
        if report.staged:
            _stage_inputs(report, out)
        started = time.perf_counter()
        assert report.write is not None  # select_reports returns regenerated reports only
        report.write(report, written.parent)
        outcomes.append(Outcome(report, written, time.perf_counter() - started))
    return outcomes


def written_at(report: Report, out: Path) -> Path:
    """Where :func:`regenerate` writes ``report`` in ``out`` (laid out as ``results/``): at its path there; a page
    outside ``results/`` (``../README.md``) in ``out``'s :data:`OUTSIDE_RESULTS` folder, or, when ``out`` is
    ``results/`` itself, over the committed file."""
    path = Path(report.path)
    if path.parts[0] != "..":
        return out / path
    if out.resolve() == RESULTS_DIR.resolve():
        return (out / path).resolve()
    return out / OUTSIDE_RESULTS / path.relative_to("..")


def comparable_text(text: str) -> str:
    """``text`` without its provenance lines: the lines of the preamble (before the first section, code block
    or table) that start with one of :data:`PROVENANCE_PREFIXES`. Everything else is kept byte for byte, so a
    changed number, word or blank line still counts as a difference."""
    kept = []
    preamble = True
    for line in text.splitlines(keepends=True):
        preamble = preamble and not line.startswith(CONTENT_STARTS)
        if not (preamble and line.startswith(PROVENANCE_PREFIXES)):
            kept.append(line)
    return "".join(kept)


def differences(report: Report, written: Path) -> str:
    """A unified diff of the committed ``report`` against the one at ``written`` (provenance lines left
    out); empty when they agree."""
    committed = RESULTS_DIR / report.path
    before = comparable_text(committed.read_text()) if committed.is_file() else ""
    after = comparable_text(Path(written).read_text())
    return "".join(
        difflib.unified_diff(
            before.splitlines(keepends=True),
            after.splitlines(keepends=True),
            f"results/{report.path} ({'committed' if committed.is_file() else 'not committed'})",
            f"{report.path} (regenerated)",
        )
    )


def listing() -> list[str]:
    """One line per ``results/**/*.md`` in the registry: its path, then how it is regenerated (name and
    command) or why it is not; a report whose data is not committed says so."""
    width = max(len(report.path) for report in REPORTS)
    lines = []
    for report in REPORTS:
        if report.regenerated:
            missing = missing_inputs(report)
            note = f" [skipped: {missing}]" if missing else ""
            lines.append(f"{report.path:<{width}}  regenerated as {report.name}: {report.command}{note}")
        else:
            lines.append(f"{report.path:<{width}}  not regenerated: {report.reason}")
    return lines
