"""The benchmark report and the README's results block: the claim wording on small synthetic tables, each
comparison of two agents taken from a paired test, every branch of the templates, the marker blocks, a missing
input, and (slow: minutes of bootstraps) the committed outputs being exactly what the writers make of the
committed data."""

from __future__ import annotations

import re
import shutil
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from agents.common.jinja_reports import render, template_source
from agents.common.locations import REPO_ROOT, RESULTS_DIR
from agents.evaluation.paired import Comparison
from agents.studies.benchmark_claims import (
    WINNER,
    agents_broken_by,
    breaks_phrase,
    every_or_all_but,
    paired_reading,
    verdict,
)
from agents.studies.benchmark_data import INPUTS, BenchmarkData
from agents.studies.benchmark_report import (
    BENCHMARK_TEMPLATE,
    PACKAGE,
    README_MARKERS,
    README_TEMPLATE,
    THESIS_MARKERS,
    THESIS_TEMPLATE,
    replace_block,
    report_values,
    template_fields,
    write_benchmark,
    write_readme_results,
    write_thesis_closed_loop,
)
from agents.studies.benchmark_values import best_agents, reactive_gap_values
from agents.studies.flow_gap_report import FLOW_GAP_TEMPLATE


def _row(agent: str, levels: list[float], breaking: float | None, factor: str = "rotation_noise_deg") -> dict:
    return {"agent": agent, "factor": factor, "side": "above", "levels": levels, "breaking_level": breaking}


# A noise floor flown at 0.5 and 2: three agents break at 0.5, vfh at 2, ppo_robust never.
TABLE = [
    _row("bee", [0.5, 2.0], 0.5),
    _row("bee_ttc", [0.5, 2.0], 0.5),
    _row("vfh", [0.5, 2.0], 2.0),
    _row("ppo_flow@all", [0.5, 2.0], 0.5),
    _row("ppo_robust@all", [0.5, 2.0], None),
    _row("bee", [0.1, 0.3], 0.1, "translation_drift"),
]


def test_every_or_all_but_words_the_exact_set() -> None:
    members = ["`a`", "`b`", "`c`", "`d`", "`e`"]
    assert every_or_all_but(members, members) == "every agent"
    assert every_or_all_but(members, []) == "no agent"
    assert every_or_all_but(members, members[:4]) == "all agents but `e`"
    assert every_or_all_but(members, members[:3]) == "all agents but `d` and `e`"
    assert every_or_all_but(members, members[:2]) == "`a` and `b` but not `c`, `d` or `e`"
    assert every_or_all_but(members[:2], members[:1]) == "`a` but not `b`"


def test_agents_broken_by_counts_a_break_at_or_before_the_level() -> None:
    assert agents_broken_by(TABLE, "rotation_noise_deg", 0.5) == (
        ["bee", "bee_ttc", "ppo_flow@all"],
        ["vfh", "ppo_robust@all"],
    )
    assert agents_broken_by(TABLE, "rotation_noise_deg", 2.0) == (
        ["bee", "bee_ttc", "vfh", "ppo_flow@all"],
        ["ppo_robust@all"],
    )
    # "breaks every flow agent" only where it holds; "all but" names who is left out.
    assert breaks_phrase(TABLE, "rotation_noise_deg", 0.5) == "all agents but `vfh` and `ppo_robust`"
    assert breaks_phrase(TABLE, "rotation_noise_deg", 2.0) == "all agents but `ppo_robust`"
    assert breaks_phrase(TABLE[2:5], "rotation_noise_deg", 0.5) == "`ppo_flow` but not `vfh` or `ppo_robust`"
    assert breaks_phrase(TABLE, "translation_drift", 0.3) == "every agent"
    with pytest.raises(ValueError, match="no agent"):
        agents_broken_by(TABLE, "rotation_noise_deg", 1.0)


@pytest.mark.parametrize(
    ("low", "high", "expected"),
    [
        (-0.05, -0.01, "the winner fails less than `bee_ttc`"),
        (0.002, 0.038, "`bee_ttc` fails less than the winner"),
        (-0.01, 0.02, "no difference shown"),
    ],
)
def test_a_comparison_is_worded_from_its_paired_interval(low: float, high: float, expected: str) -> None:
    found = Comparison(WINNER, "bee_ttc", (low + high) / 2, low, high, 0.5, 1.0)
    assert verdict(found) == expected
    assert paired_reading(found) == (
        f"paired by layout, the winner − `bee_ttc` = {found.difference:+.3f} [{low:+.3f}, {high:+.3f}]: {expected}"
    )
    assert verdict(found, "flow", "truth") == expected.replace("the winner", "flow").replace(
        "`bee_ttc`", "truth"
    )


def _layouts_failed(count: int, runs: int = 1, layouts: int = 300) -> np.ndarray:
    """``runs`` runs that each fail the first ``count`` of ``layouts`` layouts."""
    matrix = np.zeros((runs, layouts))
    matrix[:, :count] = 1.0
    return matrix


def _clean_table(failures: dict[str, np.ndarray]) -> SimpleNamespace:
    """A stand-in for :class:`BenchmarkData` holding only the leading table, from failure matrices."""
    rows = [
        {"agent": a, "failure_rate": m.mean(), "failure_low": 0.0, "failure_high": 1.0, "runs": m.shape[0]}
        for a, m in failures.items()
    ]
    data = SimpleNamespace(leaderboard=rows, failures=failures)
    data.row = lambda agent: next(r for r in rows if r["agent"] == agent)
    data.compare = lambda agent, reference: BenchmarkData.compare(data, agent, reference)
    return data


@pytest.mark.parametrize(
    ("winner_failures", "verdict_text", "learned_beats", "reactive_beats"),
    [
        (60, "`bee_ttc` fails less than the winner", False, True),
        (0, "the winner fails less than `bee_ttc`", True, False),
        (30, "no difference shown", False, False),
    ],
)
def test_the_reactive_gap_is_read_from_paired_tests(
    winner_failures: int, verdict_text: str, learned_beats: bool, reactive_beats: bool
) -> None:
    data = _clean_table(
        {
            "bee_robust": _layouts_failed(45),
            "bee_ttc": _layouts_failed(30),
            "ppo_flow": _layouts_failed(90, runs=5),
            "ppo_oracle": _layouts_failed(0, runs=5),  # privileged: never the best learned agent
            WINNER: _layouts_failed(winner_failures, runs=5),
        }
    )
    assert best_agents(data)[1]["agent"] == WINNER
    values = reactive_gap_values(data)
    found = data.compare(WINNER, "bee_ttc")
    assert found.difference == pytest.approx((winner_failures - 30) / 300)
    assert values["winner_vs_ttc"] == paired_reading(found) and values["winner_vs_ttc"].endswith(verdict_text)
    assert values["best_learned_vs_reactive"] == values["winner_vs_ttc"]
    assert (
        values["learned_beats_reactive"] is learned_beats
        and values["reactive_beats_learned"] is reactive_beats
    )
    assert values["ppo_flow_vs_ttc"].endswith("`bee_ttc` fails less than `ppo_flow`")


_CONDITION = re.compile(r"\{%\+?\s*if\s+(\w+)\s*\+?%\}")


def _render_with(template: str, true: set[str]) -> str:
    conditions = set(_CONDITION.findall(template_source(PACKAGE, template)))
    values: dict[str, str | bool] = {name: f"<{name}>" for name in template_fields(template) - conditions}
    values.update({name: name in true for name in conditions})
    return render(PACKAGE, template, values)


@pytest.mark.parametrize("template", [BENCHMARK_TEMPLATE, README_TEMPLATE, FLOW_GAP_TEMPLATE])
def test_every_branch_of_a_template_renders(template: str) -> None:
    conditions = set(_CONDITION.findall(template_source(PACKAGE, template)))
    texts = {_render_with(template, set()), _render_with(template, conditions)}
    texts |= {_render_with(template, {name}) for name in conditions}
    assert conditions and all(
        "{{" not in text and "{%" not in text and "overlap" not in text for text in texts
    )


@pytest.mark.parametrize(
    ("template", "true", "headline"),
    [
        (
            README_TEMPLATE,
            {"reactive_beats_learned"},
            "The best tuned reactive rule still fails less than the best learned",
        ),
        (
            README_TEMPLATE,
            {"learned_beats_reactive"},
            "The best learned flow policy fails less than the best reactive",
        ),
        (README_TEMPLATE, set(), "the best learned flow policy and the best reactive rule are not told"),
        (
            BENCHMARK_TEMPLATE,
            {"reactive_beats_learned"},
            "**Nothing, on clean courses: the best reactive agent",
        ),
        (
            BENCHMARK_TEMPLATE,
            {"learned_beats_reactive"},
            "(<best_learned>) fails less than the best reactive",
        ),
        (BENCHMARK_TEMPLATE, set(), "are not told apart** (<best_learned_vs_reactive>)"),
    ],
)
def test_the_headline_follows_the_paired_verdict(template: str, true: set[str], headline: str) -> None:
    assert headline in " ".join(_render_with(template, true).split())


def test_replace_block_is_idempotent_and_keeps_the_rest() -> None:
    start, end = README_MARKERS
    text = f"# Title\n\n## Results\n\n{start}\nold numbers 0.11\n{end}\n\n- a link, kept\n"
    once = replace_block(text, README_MARKERS, "new numbers 0.08\n")
    assert once == f"# Title\n\n## Results\n\n{start}\nnew numbers 0.08\n{end}\n\n- a link, kept\n"
    assert replace_block(once, README_MARKERS, "new numbers 0.08\n") == once
    for broken in (text.replace(end, ""), text + f"{start}\n", f"{end}\n{text.replace(end, '')}"):
        with pytest.raises(ValueError, match="results:"):
            replace_block(broken, README_MARKERS, "x")


def test_a_missing_input_is_named_in_one_line(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError) as caught:
        write_benchmark(tmp_path, tmp_path / "out", "test")
    assert "leaderboard_episodes.csv" in str(caught.value) and "\n" not in str(caught.value)
    for name in list(INPUTS)[:2]:
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text("")
    with pytest.raises(FileNotFoundError, match=r"sweep_episodes\.csv") as caught:
        write_benchmark(tmp_path, tmp_path / "out", "test")
    assert "\n" not in str(caught.value)
    assert not (tmp_path / "out").exists()


def _without_generated(text: str) -> list[str]:
    return [line for line in text.splitlines() if not line.startswith("Generated ")]


@pytest.mark.slow
def test_the_committed_benchmark_is_what_the_writer_makes(tmp_path: Path) -> None:
    lines = write_benchmark(RESULTS_DIR, tmp_path, "test")
    written = (tmp_path / "benchmark.md").read_text()
    assert lines == written.splitlines()
    assert sum(line.startswith("Generated ") for line in lines) == 1
    assert _without_generated(written) == _without_generated((RESULTS_DIR / "benchmark.md").read_text())
    assert sorted(p.name for p in tmp_path.iterdir()) == ["benchmark.md"]


@pytest.mark.slow
def test_every_value_is_used_and_every_field_has_one() -> None:
    from agents.studies.benchmark_data import load_benchmark_data

    values = set(report_values(load_benchmark_data(RESULTS_DIR)))
    fields = set().union(
        *(template_fields(t) for t in (BENCHMARK_TEMPLATE, README_TEMPLATE, THESIS_TEMPLATE))
    )
    assert values == fields - {"generated", "command"}


def _outside(text: str, markers: tuple[str, str]) -> tuple[str, str]:
    head, rest = text.split(markers[0])
    return head, rest.split(markers[1])[1]


@pytest.mark.parametrize(
    ("source", "writer", "markers"),
    [
        (REPO_ROOT / "README.md", write_readme_results, README_MARKERS),
        (RESULTS_DIR / "thesis" / "DISCUSSION.md", write_thesis_closed_loop, THESIS_MARKERS),
        (RESULTS_DIR / "thesis" / "README.md", write_thesis_closed_loop, THESIS_MARKERS),
    ],
)
def test_generated_blocks_are_committed_idempotent_and_local(tmp_path: Path, source, writer, markers) -> None:
    committed = source.read_text()
    copy = tmp_path / source.name
    shutil.copyfile(source, copy)
    assert writer(RESULTS_DIR, copy) == committed
    # Text outside the markers is never touched, whatever the block held before.
    stale = replace_block(committed, markers, "stale numbers 0.47\n")
    copy.write_text(stale)
    first = writer(RESULTS_DIR, copy)
    assert first == committed and copy.read_text() == committed
    assert writer(RESULTS_DIR, copy) == first
    assert _outside(first, markers) == _outside(stale, markers)


@pytest.mark.slow
def test_the_winners_true_depth_recipe_is_worded_once_it_is_in_the_leading_table() -> None:
    import dataclasses

    from agents.studies.benchmark_claims import WINNER, WINNER_ON_TRUE_DEPTHS
    from agents.studies.benchmark_data import load_benchmark_data
    from agents.studies.benchmark_values import reactive_gap_values

    data = load_benchmark_data(RESULTS_DIR)
    others = [r for r in data.leaderboard if r["agent"] != WINNER_ON_TRUE_DEPTHS]
    assert reactive_gap_values(dataclasses.replace(data, leaderboard=others))["truth_recipe_flown"] is False
    # a twin failing on the winner's own layouts shows no difference, paired by layout
    twin = {**data.row(WINNER), "agent": WINNER_ON_TRUE_DEPTHS}
    failures = {**data.failures, WINNER_ON_TRUE_DEPTHS: data.failures[WINNER]}
    values = reactive_gap_values(dataclasses.replace(data, leaderboard=[*others, twin], failures=failures))
    assert values["truth_recipe_flown"] is True and values["fail_truth_recipe"] == values["fail_winner"]
    assert values["winner_vs_truth_recipe"].endswith(": no difference shown")


@pytest.mark.slow
def test_the_committed_comparisons_are_paired_tests_on_the_leading_tables_layouts() -> None:
    from agents.studies.benchmark_data import load_benchmark_data

    data = load_benchmark_data(RESULTS_DIR)
    assert data.failures[WINNER].shape == (5, len(data.layouts))
    found = data.compare(WINNER, "bee_ttc")
    assert found.difference == pytest.approx(
        data.row(WINNER)["failure_rate"] - data.row("bee_ttc")["failure_rate"]
    )
    values = report_values(data)
    assert values["winner_vs_ttc"] == paired_reading(found)
    assert values["flow_vs_oracle"] == paired_reading(data.compare("ppo_flow", "ppo_oracle"))
    assert values["reactive_beats_learned"] is (found.fails_less == "bee_ttc")
    assert not any("overlap" in str(value) for value in values.values())
