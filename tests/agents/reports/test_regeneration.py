"""``flownav reports``: every committed machine-written report is what the current code writes from the committed
episodes (the guard against a report left behind by a code change), every results/**/*.md is accounted for, and
only provenance lines are ignored when comparing."""

from __future__ import annotations

import argparse
import importlib
import shlex
import shutil
import sys
from pathlib import Path

import pytest

from agents.cli import COMMANDS, main
from agents.cli.arguments import tier_name_of
from agents.common.locations import REPO_ROOT, RESULTS_DIR
from agents.reports import ablation_entry, regeneration
from agents.reports.ablation_entry import AblationSpec
from agents.reports.benchmark_report import README_MARKERS
from agents.reports.regeneration import (
    OUTSIDE_RESULTS,
    REPORTS,
    comparable_text,
    differences,
    regenerate,
    report_names,
    select_reports,
    written_at,
)
from agents.reports.report_registry import ABLATIONS, CAMERA_STUDENT_CONFIRMATION
from agents.studies import ablation
from agents.training.multiseed import parse_seeds


@pytest.mark.parametrize("name", report_names())
def test_every_committed_report_is_what_the_code_writes_from_the_committed_data(
    name: str, tmp_path: Path
) -> None:
    (outcome,) = regenerate(tmp_path, [name])
    if outcome.written is None:
        pytest.skip(f"{outcome.report.path}: {outcome.skipped}")
    assert outcome.written == written_at(outcome.report, tmp_path)
    assert (RESULTS_DIR / outcome.report.path).is_file(), f"results/{outcome.report.path} is not committed"
    # On failure: `flownav reports --check --only NAME` shows the diff; `--out results --only NAME` rewrites it.
    assert differences(outcome.report, outcome.written) == ""


def test_regenerating_elsewhere_leaves_the_committed_report_and_its_data_alone(tmp_path: Path) -> None:
    (report,) = select_reports(["ablation-speed-1.5"])
    committed = [RESULTS_DIR / report.path, *(RESULTS_DIR / report.path).parent.rglob("*.csv")]
    before = {path: (path.stat().st_mtime_ns, path.stat().st_size) for path in committed}
    (outcome,) = regenerate(tmp_path, ["ablation-speed-1.5"])
    assert outcome.written == tmp_path / "ablation/speed_1.5/ablation.md" and outcome.written.is_file()
    assert (tmp_path / "ablation/speed_1.5/reference/bee_ttc.csv").is_file()  # its input, copied beside it
    assert {path: (path.stat().st_mtime_ns, path.stat().st_size) for path in committed} == before


def test_regenerating_never_replaces_a_different_file_at_an_inputs_place(tmp_path: Path) -> None:
    # Episodes flown into another checkout's results/ and not committed yet must survive a report run there.
    (report,) = select_reports(["ablation-speed-1.5"])
    regenerate(tmp_path, ["ablation-speed-1.5"])
    staged = tmp_path / "ablation/speed_1.5/reference/bee_ttc.csv"
    staged.write_text(staged.read_text() + "a row not committed yet\n")
    kept = staged.read_bytes()
    with pytest.raises(
        ValueError, match=r"bee_ttc\.csv differs from the committed .* regenerate into a fresh --out"
    ):
        regenerate(tmp_path, ["ablation-speed-1.5"])
    assert staged.read_bytes() == kept
    assert report.path == "ablation/speed_1.5/ablation.md"


def test_a_report_whose_data_is_not_committed_is_skipped_and_says_so(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(regeneration, "RESULTS_DIR", tmp_path / "results")
    (outcome,) = regenerate(tmp_path / "out", ["leaderboard"])
    assert outcome.written is None
    assert outcome.skipped == "no results/leaderboard_episodes.csv (its data is not committed)"
    assert not (tmp_path / "out").exists()


def test_check_prints_a_diff_and_exits_1_when_a_committed_report_differs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    results = tmp_path / "results"
    shutil.copytree(RESULTS_DIR / "ablation" / "speed_1.5", results / "ablation" / "speed_1.5")
    monkeypatch.setattr(regeneration, "RESULTS_DIR", results)
    assert main(["reports", "--check", "--only", "ablation-speed-1.5"]) == 0
    assert "ablation/speed_1.5/ablation.md: same" in capsys.readouterr().out

    committed = results / "ablation" / "speed_1.5" / "ablation.md"
    text = committed.read_text()
    committed.write_text(
        text.replace("| bee_ttc (reactive, reference) | - | 50 |", "| bee_ttc (x) | - | 50 |")
    )
    assert main(["reports", "--check", "--only", "ablation-speed-1.5"]) == 1
    out = capsys.readouterr().out
    assert "ablation/speed_1.5/ablation.md: differs" in out
    assert "\n-| bee_ttc (x) | - | 50 |" in out and "\n+| bee_ttc (reactive, reference) | - | 50 |" in out
    assert "1 of 1 reports differ from the committed ones; 0 skipped (no data)" in out


def test_comparable_text_drops_the_provenance_lines_and_nothing_else() -> None:
    text = (
        "# Sweep: failure rate per agent and sensor error\n"
        "\n"
        "Generated 2026-12-02 21:54 UTC by `flownav leaderboard --out results` (code: commit `bb3f880`). AMD EPYC\n"
        "Command: `flownav sweep --config configs/sweep.yaml --out results`  \n"
        "Config: `configs/sweep.yaml`  \n"
        "Code when this report was written: commit `c64bb31`  \n"
        "Hardware: AMD EPYC, 2 cores, Python 3.11.7  \n"
        "Wall time of the last invocation: 3.9 min (episodes already in the CSV are not re-flown).\n"
        "Rebuilt with `--report-only` from the episodes flown so far, on (...): AMD EPYC, 2 cores\n"
        "A paragraph that mentions Generated reports and Hardware: kept.\n"
        "\n"
        "| agent | failure |\n"
        "|---|---|\n"
        "| bee | 0.15 [0.09, 0.23] |\n"
        "\n"
        "## Later\n"
        "Generated here is content, after the preamble.\n"
        "Hardware: so is this.   \n"
        "no newline at the end"
    )
    assert comparable_text(text) == (
        "# Sweep: failure rate per agent and sensor error\n"
        "\n"
        "Command: `flownav sweep --config configs/sweep.yaml --out results`  \n"
        "Config: `configs/sweep.yaml`  \n"
        "A paragraph that mentions Generated reports and Hardware: kept.\n"
        "\n"
        "| agent | failure |\n"
        "|---|---|\n"
        "| bee | 0.15 [0.09, 0.23] |\n"
        "\n"
        "## Later\n"
        "Generated here is content, after the preamble.\n"
        "Hardware: so is this.   \n"
        "no newline at the end"
    )


def test_comparable_text_keeps_what_follows_a_code_block_or_table_start() -> None:
    for opening in ("```yaml\n", "| a |\n"):
        text = f"# T\n\n{opening}Generated inside the content\nHardware: inside too\n"
        assert comparable_text(text) == text
    assert comparable_text("") == ""


def test_a_bad_only_name_is_one_line_naming_it_and_the_allowed_names(
    capsys: pytest.CaptureFixture[str],
) -> None:
    allowed = ", ".join(report_names())
    message = f"--only: no regenerated report is called 'lab-notes' (one of: {allowed})"
    with pytest.raises(ValueError) as error:
        select_reports(["leaderboard", "lab-notes"])
    assert type(error.value) is ValueError and str(error.value) == message
    assert main(["reports", "--only", "leaderboard,lab-notes"]) == 2
    assert capsys.readouterr().err == f"flownav reports: error: {message}\n"


def test_check_takes_no_out(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["reports", "--check", "--out", "x", "--only", "suite"]) == 2
    assert "--check writes to a temporary folder of its own; it takes no --out" in capsys.readouterr().err


def test_list_names_every_markdown_file_of_results_exactly_once(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["reports", "--list"]) == 0
    lines = {line.split()[0]: line for line in capsys.readouterr().out.splitlines()}
    assert len(lines) == len(REPORTS), "a report is listed twice"
    committed = {path.relative_to(RESULTS_DIR).as_posix() for path in RESULTS_DIR.rglob("*.md")}
    assert not committed - set(lines), "reports of results/ missing from agents/reports/regeneration.py"
    for path, line in lines.items():
        assert " regenerated as " in line or " not regenerated: " in line, line
        if not (
            RESULTS_DIR / path
        ).is_file():  # only a report whose data is not committed yet (the suite's, say)
            assert " regenerated as " in line and line.endswith(" (its data is not committed)]"), line


def test_every_report_is_regenerated_or_says_why_not() -> None:
    for report in REPORTS:
        assert bool(report.name) == report.regenerated == bool(report.command) == (not report.reason), report
    assert len(report_names()) == len(set(report_names()))


ABLATION_SPECS = {spec.name: spec for spec in (*ABLATIONS, CAMERA_STUDENT_CONFIRMATION)}


def _parsed(command: str) -> argparse.Namespace:
    words = shlex.split(command)
    assert words[0] == "flownav", command
    parser = argparse.ArgumentParser()
    importlib.import_module(COMMANDS[words[1]]).add_arguments(parser)
    return parser.parse_args(words[2:])


@pytest.mark.parametrize("report", [r for r in REPORTS if r.regenerated], ids=lambda r: r.name)
def test_each_command_is_a_valid_report_only_call_that_writes_where_the_report_lives(report) -> None:
    args = _parsed(report.command)
    if report.command.startswith("flownav reports "):  # written by this command itself, into results/
        assert Path(args.out) == Path("results") and args.only == report.name
        return
    assert Path(args.out) == Path("results") / Path(report.path).parent
    if hasattr(args, "report_only"):
        assert args.report_only, report.command
    spec = ABLATION_SPECS.get(report.name)
    if spec is not None:  # the named options of the spec the command and the writer are both derived from
        assert report.write == spec.write and report.command == spec.command
        assert [str(path) for path in args.configs] == list(spec.configs)
        assert args.layouts == spec.layouts and tuple(args.env) == spec.env
        assert tuple(parse_seeds(args.seeds)) == spec.seeds
        assert args.reference == ",".join(spec.reference)
        assert (args.tiers and tier_name_of(args.tiers)) == spec.tier
        assert args.suite_version == spec.suite_version or not args.tiers
        assert args.confirm == spec.confirm


@pytest.mark.parametrize("spec", ABLATION_SPECS.values(), ids=lambda spec: spec.name)
def test_an_ablation_report_is_written_with_the_values_its_command_gives_flownav_ablation(
    spec: AblationSpec, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls: list[tuple[tuple[object, ...], dict[str, object]]] = []

    def compare_configs(*args: object, **options: object) -> list[str]:
        calls.append((args, options))
        return []

    monkeypatch.setattr(ablation, "compare_configs", compare_configs)  # what the command line imports on use
    monkeypatch.setattr(ablation_entry, "compare_configs", compare_configs)
    monkeypatch.setattr(sys, "argv", shlex.split(spec.command))
    (report,) = select_reports([spec.name])
    assert main(shlex.split(spec.command)[1:]) == 0
    report.write(report, tmp_path)
    (cli_args, cli), (registry_args, registry) = calls
    assert registry_args[0] == [REPO_ROOT / path for path in cli_args[0]]  # configs: the same files
    assert registry_args[1] == cli_args[1] and registry_args[2] == tmp_path  # seeds; the folder written
    same = (
        "episodes",
        "report_only",
        "command",
        "reference_agents",
        "env",
        "tier",
        "suite_version",
        "confirm",
    )
    assert {key: registry[key] for key in same} == {key: cli[key] for key in same}


def test_the_readmes_results_block_is_a_report_of_its_own(tmp_path: Path) -> None:
    # Its regeneration is compared with the committed README by the test above, as every report's.
    (report,) = select_reports(["readme-results"])
    assert (
        "readme-results" not in select_reports(["benchmark"])[0].command
    )  # benchmark.md alone writes no README
    # Published (--out results) over the committed README; anywhere else beside the pages, never above the folder.
    assert written_at(report, RESULTS_DIR) == REPO_ROOT / "README.md"
    assert written_at(report, tmp_path) == tmp_path / OUTSIDE_RESULTS / "README.md"
    # The whole README is compared, so a stale block is a difference (and the text outside it is the committed one).
    start = f"{README_MARKERS[0]}\n"
    stale = tmp_path / "README.md"
    stale.write_text((REPO_ROOT / "README.md").read_text().replace(start, f"{start}stale 0.47\n"))
    changed = [line for line in differences(report, stale).splitlines() if line[:1] in "+-"]
    assert changed[2:] == ["+stale 0.47"]
