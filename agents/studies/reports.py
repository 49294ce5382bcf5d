"""Every Markdown report in ``results/``, and how to write the machine-written ones again from the committed
data without flying anything (``flownav reports``).

A report's numbers should be what the current code makes of the committed episodes: when a statistic changes
(a bootstrap interval, a table's layout), a report written before the change silently disagrees with the code
that claims to produce it. :data:`REPORTS` lists every ``results/**/*.md``: each machine-written report with a
report-only path names its inputs and the writer call that rebuilds it, in-process; every other one (prose,
measurements of a machine's speed, stale archives) says in one line why it is not regenerated.
:func:`regenerate` writes the reports into any folder with the layout of ``results/``, and :func:`differences`
compares one with the committed file, ignoring only the lines that record when, where and with which commit it
was written (:func:`comparable_text`).
"""

from __future__ import annotations

import contextlib
import difflib
import os
import shutil
import tempfile
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

from agents.common.locations import REPO_ROOT, RESULTS_DIR

# Lines of a report's preamble that record how it was made, not what it says: every writer but the sweep's puts
# the date, command, commit and machine on one "Generated ..." line; the sweep's header
# (agents/evaluation/sweep_report.write_report) gives the commit, the machine and the wall time lines of their own.
PROVENANCE_PREFIXES = (
    "Generated ",
    "Code when this report was written: ",
    "Hardware: ",
    "Wall time of the last invocation: ",
    "Rebuilt with `--report-only` from the episodes flown so far",
)
# The preamble ends where the report's content starts: its first section, code block or table.
CONTENT_STARTS = ("## ", "```", "|")


@dataclass(frozen=True)
class Report:
    """One Markdown file of ``results/``.

    Attributes:
        path: the report, relative to ``results/`` (``ablation/speed_1.5/ablation.md``).
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
    write: Callable[[Report, Path], None] | None = None
    staged: bool = True
    reason: str = ""

    @property
    def regenerated(self) -> bool:
        return self.write is not None


@dataclass(frozen=True)
class Outcome:
    """What :func:`regenerate` did with one report: where it wrote it (None: skipped, ``skipped`` says why)
    and how long the writer took."""

    report: Report
    written: Path | None
    seconds: float = 0.0
    skipped: str = ""


@contextlib.contextmanager
def _repository_as_cwd() -> Iterator[None]:
    """Run a writer from the repository root, then return: the sweep's report prints its config path as given
    (``configs/sweep.yaml``) and reads the config through it, so the text is the same wherever this runs."""
    before = Path.cwd()
    os.chdir(REPO_ROOT)
    try:
        yield
    finally:
        os.chdir(before)


def _leaderboard(report: Report, folder: Path) -> None:
    from agents.evaluation.leaderboard import run_leaderboard
    from agents.policies import AGENT_NAMES

    run_leaderboard(AGENT_NAMES, folder, report_only=True, command=report.command)


def _sweep(report: Report, folder: Path, *, config: str) -> None:
    from agents.evaluation.sweep import run_sweep

    # `flownav sweep` leaves --report-only out of the command it prints; the report's "Rebuilt with" line says it.
    with _repository_as_cwd():
        run_sweep(
            Path(config), folder, report_only=True, command=report.command.replace(" --report-only", "")
        )


def _error_analysis(report: Report, folder: Path) -> None:
    # The same calls as agents/cli/error_analysis.py with its default --baseline (the leaderboard's episodes).
    from agents.evaluation.records import read_records
    from agents.evaluation.sweep import pool_every_seed
    from agents.studies.error_analysis_report import write_error_analysis

    rows = pool_every_seed(read_records(RESULTS_DIR / "sweep_episodes.csv"))
    baseline = pool_every_seed(read_records(RESULTS_DIR / "leaderboard_episodes.csv"))
    write_error_analysis(rows, folder, report.command, baseline)


def _ablation(
    report: Report,
    folder: Path,
    *,
    configs: Sequence[str],
    episodes: int,
    env: Mapping[str, Any],
) -> None:
    from agents.studies.ablation import compare_configs

    # Run folders (runs/) are not committed: an empty one makes every seed its shipped policy, as on a fresh
    # checkout, so the report does not depend on what this machine trained.
    with tempfile.TemporaryDirectory(prefix="flownav-no-runs-") as no_runs:
        compare_configs(
            [REPO_ROOT / config for config in configs],
            ABLATION_SEEDS,
            folder,
            runs_dir=Path(no_runs),
            episodes=episodes,
            report_only=True,
            command=report.command,
            reference_agents=ABLATION_REFERENCE,
            env=env,
        )


def _calibration(report: Report, folder: Path) -> None:
    # The same calls as agents/cli/calibrate_tiers.py, which writes calibration.md itself.
    from agents.common.folders import write_text_atomically
    from agents.studies.tier_calibration import report_lines, run_calibration

    result = run_calibration(folder, report_only=True)
    write_text_atomically(folder / "calibration.md", "\n".join(report_lines(result, report.command)) + "\n")


def _confirmation(report: Report, folder: Path) -> None:
    # The same calls as agents/cli/confirm.py: the fresh flights staged in the folder, the search's from results/.
    from agents.common.folders import write_text_atomically
    from agents.studies.confirmation import report_lines, run_confirmation, search_record

    result = run_confirmation(folder, report_only=True)
    lines = report_lines(result, search_record(RESULTS_DIR / "ablation"), report.command)
    write_text_atomically(folder / "confirmation.md", "\n".join(lines) + "\n")


def _benchmark(report: Report, folder: Path) -> None:
    from agents.studies.benchmark_report import write_benchmark

    write_benchmark(folder, folder, report.command)


def _thesis_block(report: Report, folder: Path) -> None:
    # Only the closed-loop paragraph between its markers is written from data; flownav replicate owns the rest.
    from agents.studies.benchmark_report import write_thesis_closed_loop

    root = folder
    for _ in Path(report.path).parent.parts:  # the folder with the layout of results/ that holds the data
        root = root.parent
    write_thesis_closed_loop(root, root / report.path)


# What benchmark.md and the thesis's closed-loop paragraph are written from (agents/studies/benchmark_data.py).
BENCHMARK_INPUTS = (
    "leaderboard_episodes.csv",
    "training_seeds.csv",
    "sweep_episodes.csv",
    "diagnostics/reactive_oracle_episodes.csv",
    "thesis/three_capsule.json",
    "ablation/*/seed_*.csv",
    "ablation/*/*/seed_*.csv",
    "ablation/reference/*.csv",
    "ablation/*/reference/*.csv",
    "policies/*/seed_*.json",
    "policies/*/seed_*.yaml",
)


def _suite(report: Report, folder: Path) -> None:
    from agents.evaluation.suite import run_suite
    from agents.policies import AGENT_NAMES

    run_suite(AGENT_NAMES, folder, report_only=True, command=report.command)


ABLATION_SEEDS = range(5)
ABLATION_REFERENCE = ("bee_robust", "bee_ttc")
_LEVERS = tuple(
    f"configs/experiments/ppo_flow_{lever}.yaml"
    for lever in (
        "course",
        "nearness",
        "course_approach",
        "course_approach_stack4",
        "course_approach_curriculum",
        "course_approach_smooth",
        "course_approach_curriculum_slow",
    )
)
_CLEAN_ABLATION = ("configs/ppo_flow.yaml", "configs/ppo_oracle.yaml", "configs/ppo_robust.yaml", *_LEVERS)
_CONDITION_ABLATION = ("configs/ppo_flow.yaml", *_LEVERS)


def _ablation_report(folder: str, configs: Sequence[str], episodes: int, env: Mapping[str, Any]) -> Report:
    """An ``ablation.md``, its command written from the same settings the writer is called with."""
    options = f" --episodes {episodes}" + "".join(f" --env {key}={value}" for key, value in env.items())
    return Report(
        f"{folder}/ablation.md",
        name=folder.replace("/", "-").replace("_", "-"),
        command=f"flownav ablation --configs {' '.join(configs)} --seeds 0-4 "
        f"--reference {','.join(ABLATION_REFERENCE)}{options} --out results/{folder} --report-only",
        inputs=(f"{folder}/*/seed_*.csv", f"{folder}/reference/*.csv"),
        write=partial(_ablation, configs=configs, episodes=episodes, env=env),
    )


def _not_regenerated(reason: str, *paths: str) -> tuple[Report, ...]:
    return tuple(Report(path, reason=reason) for path in paths)


_PROSE = "hand-written prose"
_MEASURED = "a measurement, not a summary of committed episodes: regenerating it means measuring again (flownav bench)"
_STALE = "stale, kept for comparison as the code of its time wrote it (results/README.md)"

REPORTS: tuple[Report, ...] = (
    Report(
        "leaderboard.md",
        name="leaderboard",
        command="flownav leaderboard --out results --report-only",
        inputs=("leaderboard_episodes.csv",),
        write=_leaderboard,
    ),
    Report(
        "sweep.md",
        name="sweep",
        command="flownav sweep --config configs/sweep.yaml --out results --report-only",
        inputs=("sweep_episodes.csv",),
        write=partial(_sweep, config="configs/sweep.yaml"),
    ),
    Report(
        "error_analysis.md",
        name="error-analysis",
        command="flownav error-analysis --episodes results/sweep_episodes.csv --out results",
        inputs=("sweep_episodes.csv", "leaderboard_episodes.csv"),
        write=_error_analysis,
        staged=False,
    ),
    _ablation_report("ablation", _CLEAN_ABLATION, 100, {}),
    _ablation_report("ablation/density_0.18", _CONDITION_ABLATION, 50, {"obstacle_density": 0.18}),
    _ablation_report("ablation/speed_1.5", _CONDITION_ABLATION, 50, {"forward_speed": 1.5}),
    Report(
        "suite_calibration/calibration.md",
        name="calibrate-tiers",
        command="flownav calibrate-tiers --out results/suite_calibration --report-only",
        inputs=("suite_calibration/calibration_episodes.csv", "suite_calibration/sensor_pilot_episodes.csv"),
        write=_calibration,
    ),
    Report(
        "benchmark.md",
        name="benchmark",
        command="flownav reports --out results --only benchmark",
        inputs=BENCHMARK_INPUTS,
        write=_benchmark,
    ),
    *(
        Report(
            f"thesis/{file}",
            name=name,
            command=f"flownav reports --out results --only {name}",
            inputs=(*BENCHMARK_INPUTS, f"thesis/{file}"),
            write=_thesis_block,
        )
        for file, name in (("DISCUSSION.md", "thesis-discussion"), ("README.md", "thesis-readme"))
    ),
    Report(
        "confirmation/confirmation.md",
        name="confirm",
        command="flownav confirm --out results/confirmation --report-only",
        # Not flown on fresh layouts yet: once results/confirmation/<agent>.csv exist, add
        # "confirmation/*.csv" here and stage it (staged=True), so the regenerated report reads them.
        inputs=("ablation/*/*/seed_*.csv",),
        write=_confirmation,
        staged=False,
    ),
    Report(
        "suite.md",
        name="suite",
        command="flownav suite --out results --report-only",
        inputs=("suite_episodes.csv",),
        write=_suite,
    ),
    *_not_regenerated(
        _PROSE,
        "README.md",
        "flow_gap.md",
        "diagnostics/README.md",
        "renderer_check/README.md",
        "sweep_fast20/README.md",
        "sweep_thesis_range/README.md",
        "throughput/README.md",
        "unfinished/README.md",
    ),
    *_not_regenerated(
        _MEASURED,
        "estimator_performance.md",
        "env_performance.md",
        "training_performance.md",
        "depth_yield.md",
        "renderer_check/env_performance.md",
    ),
    *_not_regenerated(
        _STALE,
        "sweep_fast20/sweep.md",
        "sweep_thesis_range/sweep.md",
        "sweep_thesis_range/benchmark.md",
        "renderer_check/sweep.md",
        "bee_tuning/ranking.md",
    ),
    *_not_regenerated(
        "flownav tune has no report-only path: running it again resumes the study, which may fly episodes",
        "tuning/bee/tuning.md",
        "tuning/bee_robust/tuning.md",
        "tuning/vfh/tuning.md",
    ),
)


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
    ``results/``). Copies, not links: a writer that appended to a linked CSV would change the committed one."""
    for pattern in report.inputs:
        for source in sorted(RESULTS_DIR.glob(pattern)):
            target = out / source.relative_to(RESULTS_DIR)
            if target.exists() and target.samefile(source):
                continue
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
        folder = out / Path(report.path).parent
        if report.staged:
            _stage_inputs(report, out)
        started = time.perf_counter()
        assert report.write is not None  # select_reports returns regenerated reports only
        report.write(report, folder)
        outcomes.append(Outcome(report, out / report.path, time.perf_counter() - started))
    return outcomes


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
