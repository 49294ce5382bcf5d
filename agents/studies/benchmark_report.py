"""``benchmark.md``, the README's results and the thesis discussion's closed-loop paragraph, written from the
committed data alone (nothing is flown).

The prose is in Jinja2 templates in ``templates/`` (``benchmark.md.j2``, ``readme_results.md.j2``,
``thesis_closed_loop.md.j2``, rendered by :mod:`agents.common.jinja_reports`); every number
and every claim in it is computed by :mod:`agents.studies.benchmark_values`, :mod:`~agents.studies.benchmark_sweep`
and :mod:`~agents.studies.benchmark_findings` from :func:`~agents.studies.benchmark_data.load_benchmark_data`.
The README and the thesis discussion are hand-written files with one generated block each, between two marker
lines; only that block is rewritten.

Nothing is written into ``results/`` unless it is the output folder asked for.
"""

from __future__ import annotations

from pathlib import Path

from agents.common.folders import check_writable_folder
from agents.common.jinja_reports import render, template_names
from agents.common.tables import today
from agents.studies.benchmark_blocks import readme_values, thesis_values
from agents.studies.benchmark_claims import agents_broken_by, every_or_all_but
from agents.studies.benchmark_data import BenchmarkData, load_benchmark_data
from agents.studies.benchmark_findings import (
    dose_values,
    scale_values,
    task_values,
    thesis_model_values,
    winner_values,
)
from agents.studies.benchmark_sweep import breaking_values
from agents.studies.benchmark_values import (
    Values,
    leaderboard_values,
    reactive_gap_values,
    setup_values,
    validation_values,
)
from agents.studies.flow_gap_targets import flow_gap_target_values

# The templates, in this package's templates/ folder.
PACKAGE = "agents.studies"
BENCHMARK_TEMPLATE = "benchmark.md.j2"
README_TEMPLATE = "readme_results.md.j2"
THESIS_TEMPLATE = "thesis_closed_loop.md.j2"
README_MARKERS = ("<!-- results:start -->", "<!-- results:end -->")
THESIS_MARKERS = ("<!-- closed-loop:start -->", "<!-- closed-loop:end -->")
# The claim helpers, re-exported: the report's own vocabulary.
__all__ = [
    "agents_broken_by",
    "every_or_all_but",
    "replace_block",
    "report_values",
    "write_benchmark",
    "write_readme_results",
    "write_thesis_closed_loop",
]


def template_fields(template: str) -> frozenset[str]:
    """Every value this package's template ``template`` names."""
    return template_names(PACKAGE, template)


def report_values(data: BenchmarkData) -> Values:
    """Every value of the three templates, computed from ``data`` (each template takes the ones it names)."""
    values: Values = {}
    for part in (
        leaderboard_values,
        reactive_gap_values,
        validation_values,
        flow_gap_target_values,
        setup_values,
        breaking_values,
        winner_values,
        thesis_model_values,
        scale_values,
        task_values,
        dose_values,
        readme_values,
        thesis_values,
    ):
        values.update(part(data))
    return values


def _render(template: str, values: Values) -> str:
    # The three templates share one set of values, each naming the ones it words.
    return render(PACKAGE, template, values)


def write_benchmark(results_dir: Path, out: Path, command: str) -> list[str]:
    """Write ``out/benchmark.md`` from the committed data under ``results_dir``.

    Args:
        results_dir: a folder with the layout of ``results/`` (its episodes, ablations, policies' records).
        out: the output folder (created); nothing else is written.
        command: the command line the report names on its "Generated" line.

    Returns:
        The report's lines.

    Raises:
        FileNotFoundError: a missing input, named in one line.
        ValueError: an unwritable ``out``, or data the report cannot be worded from.
    """
    data = load_benchmark_data(Path(results_dir))
    values = {**report_values(data), "generated": today(), "command": command}
    text = _render(BENCHMARK_TEMPLATE, values)
    out = Path(out)
    check_writable_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "benchmark.md").write_text(text)
    return text.splitlines()


def replace_block(text: str, markers: tuple[str, str], block: str, name: str = "the file") -> str:
    """``text`` with the lines between its two marker lines replaced by ``block``; the marker lines and every
    line outside them are kept as they are.

    Raises:
        ValueError: a marker missing, repeated, or the end before the start.
    """
    lines = text.split("\n")
    found = [[i for i, line in enumerate(lines) if line.strip() == marker] for marker in markers]
    for marker, where in zip(markers, found, strict=True):
        if len(where) != 1:
            raise ValueError(f"{name} must hold the line {marker!r} exactly once, found {len(where)}")
    start, end = found[0][0], found[1][0]
    if end < start:
        raise ValueError(f"{name}: {markers[1]!r} comes before {markers[0]!r}")
    return "\n".join([*lines[: start + 1], *block.rstrip("\n").split("\n"), *lines[end:]])


def write_readme_results(results_dir: Path, readme: Path) -> str:
    """The README's text with its results block (between :data:`README_MARKERS`) written from the data under
    ``results_dir``; the file is rewritten only where the block changed, and nothing outside the markers.

    Returns:
        The README's new text.

    Raises:
        FileNotFoundError: a missing input or README.
        ValueError: the README's markers missing or repeated.
    """
    return _rewrite_block(results_dir, Path(readme), README_TEMPLATE, README_MARKERS)


def write_thesis_closed_loop(results_dir: Path, text_file: Path) -> str:
    """Like :func:`write_readme_results` for the thesis discussion's closed-loop paragraph (between
    :data:`THESIS_MARKERS`), in ``results/thesis/DISCUSSION.md`` or the ``README.md`` built from it."""
    return _rewrite_block(results_dir, Path(text_file), THESIS_TEMPLATE, THESIS_MARKERS)


def _rewrite_block(results_dir: Path, text_file: Path, template: str, markers: tuple[str, str]) -> str:
    """``text_file`` with the block between ``markers`` rendered from ``template`` and the data; written back
    only where it changed."""
    if not text_file.is_file():
        raise FileNotFoundError(f"file not found: {text_file}")
    text = text_file.read_text()
    block = _render(template, report_values(load_benchmark_data(Path(results_dir))))
    new = replace_block(text, markers, block, str(text_file))
    if new != text:
        text_file.write_text(new)
    return new
