"""The rule resolution page and figure, written from the study's result."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from agents.pages.wording import render_report
from agents.reports import rule_resolution_report
from agents.reports.rule_resolution_report import (
    FIGURE,
    PAGE,
    page_values,
    plot_rule_resolution,
    write_rule_resolution,
)
from agents.studies.rule_resolution import (
    CANDIDATES,
    REFINE_CANDIDATES,
    TODAY,
    RuleResolutionResult,
    _row,
)


def _result(confirmed: bool | None) -> RuleResolutionResult:
    today = np.zeros((1, 20))
    today[0, :12] = 1.0
    finer = today.copy()
    finer[0, :10] = 0.0
    search = [
        _row("search", "bee_ttc", TODAY, today, None),
        _row("search", "bee_ttc", CANDIDATES[2], finer, today),
    ]
    search += [_row("search", "vfh", TODAY, today, None), _row("search", "vfh", CANDIDATES[0], today, today)]
    refining = [
        _row("refinement", "bee_ttc", TODAY, today, None),
        _row("refinement", "bee_ttc", REFINE_CANDIDATES[0], finer, today),
        _row("refinement", "bee_ttc", REFINE_CANDIDATES[1], today, today),
    ]
    confirming = [] if confirmed is None else [_row("confirmation", "bee_ttc", CANDIDATES[2], finer, today)]
    picks = {"bee_robust": None, "bee_ttc": CANDIDATES[2].name, "vfh": None}
    return RuleResolutionResult(
        search + refining + confirming,
        picks,
        CANDIDATES[2].name,
        dict(picks),
        {"bee_robust": None, "bee_ttc": confirmed, "vfh": None},
        {"search": 10, "refinement": 10, "confirmation": 10},
        13,
        ["bee_robust at 3x5 (search)"],
    )


def _page(result: RuleResolutionResult) -> str:
    return render_report("rule_resolution.md.j2", page_values(result, "flownav rule-resolution", figure=True))


def test_the_page_words_each_comparison_from_its_interval_and_counts_what_was_tried() -> None:
    text = _page(_result(confirmed=True))
    assert (
        "12 configurations in the search (3 rules at 4 resolutions: 9 candidates against the rules' own)"
        in text
    )
    assert "**13 configurations were tried in all** (12 in the search, 1 new in the refinement)" in text
    assert (
        "flies `bee_ttc` at its own 3x5 and at 3x15-9bins and 3x5-9bins on 10 fresh validation layouts per tier "
        "from 976,000 (`RULE_RESOLUTION_REFINE_SEED_START`)" in text
    )
    assert "| `bee_ttc` | 3x5-9bins | 1.00 | 0.20 | 0.60 [0.39, 0.78] | +0.000 [" in text
    assert "- `bee_ttc`: picked 3x15-9bins." in text.split("## The refinement")[1]
    assert "| `bee_ttc` | 3x5 (its own) | 1.00 | 0.20 | 0.60 [0.39, 0.78] | — | — |" in text
    assert (
        "| `bee_ttc` | 3x15-9bins | 0.00 | 0.20 | 0.10 [0.03, 0.30] | -0.500 [" in text
        and "| fails less |" in text
    )
    assert "| `vfh` | 3x10 |" in text and "| +0.000 [+0.000, +0.000] | no difference shown |" in text
    assert "- `bee_ttc`: picked 3x15-9bins." in text and "- `vfh`: no finer histogram picked." in text
    assert "- `bee_ttc` at 3x15-9bins: confirmed." in text
    assert (
        "- `bee_ttc`: 3x15-9bins, confirmed, is worth a rule entry of its own in `configs/agents.yaml`"
        in text
    )
    assert "The nearest to a pick" not in text  # said only of a finished search that picked nothing
    assert "- bee_robust at 3x5 (search)" in text  # what is still to fly
    assert f"![Each candidate resolution minus the rule's own, per rule](./{FIGURE})" in text
    assert "160 episodes in all" in text


def test_a_pick_the_fresh_layouts_do_not_bear_out_is_said_to_be_unconfirmed() -> None:
    text = _page(_result(confirmed=False))
    assert "- `bee_ttc` at 3x15-9bins: not confirmed" in text
    assert (
        "- `bee_ttc`: keeps 3x5 (3x15-9bins, picked, was not confirmed on fresh layouts); no rule entry asks for "
        "a finer histogram for it." in text
    )


def test_with_no_pick_nothing_is_confirmed_and_no_rule_asks_for_a_finer_histogram() -> None:
    result = dataclasses.replace(_result(confirmed=None), refined=None, missing=[])
    result.picks["bee_ttc"] = None
    result.chosen["bee_ttc"] = None
    text = _page(result)
    assert "- `bee_ttc`: no finer histogram picked." in text.split("## The refinement")[1]
    assert "Nothing to confirm: no candidate's interval lay wholly below 0." in text
    assert text.count("no rule entry asks for a finer histogram for it") == 3


def test_the_figure_is_drawn_only_with_a_comparison(tmp_path: Path) -> None:
    assert plot_rule_resolution(_result(confirmed=True), tmp_path / FIGURE)
    assert (tmp_path / FIGURE).stat().st_size > 1000
    empty = RuleResolutionResult(
        [], {}, None, {}, {}, {"search": 1, "refinement": 1, "confirmation": 1}, 13, []
    )
    assert not plot_rule_resolution(empty, tmp_path / "none.png") and not (tmp_path / "none.png").exists()


def test_writing_reads_the_study_and_writes_page_and_figure(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(rule_resolution_report, "run_rule_resolution", lambda out, **options: _result(True))
    lines = write_rule_resolution(tmp_path, "flownav rule-resolution --report-only", report_only=True)
    assert (tmp_path / PAGE).read_text().splitlines() == lines and (tmp_path / FIGURE).is_file()
    assert lines[0] == "# The flow rules at finer depth histograms"


def test_a_finished_search_without_a_pick_names_the_candidate_nearest_to_one() -> None:
    today = np.zeros((1, 20))
    today[0, :12] = 1.0
    slightly = today.copy()
    slightly[0, :2] = 0.0
    rows = [
        _row("search", "bee_ttc", TODAY, today, None),
        _row("search", "bee_ttc", CANDIDATES[1], slightly, today),
    ]
    rows.append(_row("search", "vfh", CANDIDATES[0], today, today))
    result = RuleResolutionResult(
        rows,
        dict.fromkeys(("bee_robust", "bee_ttc", "vfh")),
        None,
        dict.fromkeys(("bee_robust", "bee_ttc", "vfh")),
        dict.fromkeys(("bee_robust", "bee_ttc", "vfh")),
        {"search": 10, "refinement": 10, "confirmation": 10},
        13,
        ["bee_ttc at 3x5 (refinement)"],
    )
    text = _page(result)
    assert "The nearest to a pick: `bee_ttc` at 3x15, -0.100 [" in text
    assert "its interval holds 0, so by the rule set before flying it is not picked." in text
    assert "Nothing to confirm" not in text  # the refinement may still pick
