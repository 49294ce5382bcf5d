"""The benchmark report and the README's and the thesis's generated blocks: who a claim holds for on small
synthetic tables, each comparison of two agents a paired test, the template phrases on every branch, the marker
blocks, a missing input, and (slow: the committed data's bootstraps) every template rendered on every branch and
the committed outputs being exactly what the writers make of the committed data."""

from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from agents.analysis.paired import MIN_RANKED_SEEDS, Comparison
from agents.common.jinja_reports import environment, template_fields
from agents.common.locations import REPO_ROOT, RESULTS_DIR
from agents.common.study_choices import choices
from agents.pages.wording import FILTERS, PACKAGE, render_report
from agents.reports.benchmark_report import (
    README_MARKERS,
    THESIS_MARKERS,
    replace_block,
    report_values,
    write_benchmark,
    write_readme_results,
    write_thesis_closed_loop,
)
from agents.reports.benchmark_sweep import broken_agents
from agents.reports.flow_gap_report import flow_gap_values
from agents.studies.benchmark_data import INPUTS, BenchmarkData, Rate, load_benchmark_data

WINNER = choices().winner
TEMPLATES = ("benchmark.md.j2", "readme_results.md.j2", "thesis_closed_loop.md.j2", "flow_gap.md.j2")


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


def _sweep(table: list[dict]) -> SimpleNamespace:
    """A stand-in for :class:`BenchmarkData` holding only a sweep's tolerance rows."""
    cells = {
        (r["agent"], r["factor"], level): Rate(0.5, 0.4, 0.6, 100) for r in table for level in r["levels"]
    }
    order = ["bee", "bee_ttc", "vfh", "ppo_flow", "ppo_robust"]
    return SimpleNamespace(tolerance=table, cells=cells, leaderboard=[{"agent": a} for a in order])


def test_a_factor_breaks_an_agent_at_or_after_its_first_breaking_level() -> None:
    data = _sweep(TABLE)
    assert broken_agents(data, "rotation_noise_deg", 0.5) == (
        ["bee", "bee_ttc", "ppo_flow@all"],
        ["vfh", "ppo_robust@all"],
    )
    assert broken_agents(data, "rotation_noise_deg", 2.0) == (
        ["bee", "bee_ttc", "vfh", "ppo_flow@all"],
        ["ppo_robust@all"],
    )
    assert broken_agents(data, "translation_drift", 0.3) == (["bee"], [])
    with pytest.raises(ValueError, match="no agent"):
        broken_agents(data, "rotation_noise_deg", 1.0)


def _phrase(call: str, macros: str = "wording.j2", **values: Any) -> str:
    """A phrase of ``macros`` (``wording.j2``'s) rendered with ``values``."""
    environment(PACKAGE).filters.update(FILTERS)
    return (
        environment(PACKAGE)
        .from_string(f'{{% import "{macros}" as w %}}{{{{ w.' + call + " }}")
        .render(**values)
    )


def test_a_claim_names_the_exact_set_it_holds_for() -> None:
    members = ["`a`", "`b`", "`c`", "`d`", "`e`"]
    for chosen, expected in (
        (members, "every agent"),
        ([], "no agent"),
        (members[:4], "all agents but `e`"),
        (members[:3], "all agents but `d` and `e`"),
        (members[:2], "`a` and `b` but not `c`, `d` or `e`"),
    ):
        assert _phrase("some(m, c)", m=members, c=chosen) == expected
    assert _phrase("some(m, c)", m=members[:2], c=members[:1]) == "`a` but not `b`"


@pytest.mark.parametrize(
    ("broken", "unbroken", "expected"),
    [
        (3, 0, "breaks every agent (0.10–0.30)"),
        (0, 2, "breaks no agent (0.10–0.20)"),
        (3, 1, "breaks all agents but `d` (0.10–0.30; `d` 0.40)"),
        (1, 2, "breaks `a` (0.10) but not `d` or `e` (0.40–0.50)"),
    ],
)
def test_a_breaking_sentence_gives_the_rates_on_each_side(broken: int, unbroken: int, expected: str) -> None:
    agents = [{"name": f"`{n}`", "rate": r} for n, r in zip("abcde", (0.1, 0.2, 0.3, 0.4, 0.5), strict=True)]
    split = {"broken": agents[:broken], "unbroken": agents[3 : 3 + unbroken] if broken else agents[:unbroken]}
    assert _phrase("breaks(b)", b=split) == expected


@pytest.mark.parametrize(
    ("low", "high", "expected"),
    [
        (-0.05, -0.01, "the winner fails less than `bee_ttc`"),
        (0.002, 0.038, "`bee_ttc` fails less than the winner"),
        (-0.01, 0.02, "no difference shown"),
    ],
)
def test_a_comparison_is_worded_from_its_paired_interval(low: float, high: float, expected: str) -> None:
    found = Comparison(WINNER, "bee_ttc", (low + high) / 2, low, high, 0.5, 1.0, agent_runs=MIN_RANKED_SEEDS)
    assert _phrase("verdict(c)", c=found) == expected
    reading = f"paired by layout, the winner − `bee_ttc` = {found.difference:+.3f} [{low:+.3f}, {high:+.3f}]: {expected}"
    assert _phrase("reading(c)", c=found) == reading
    few = dataclasses.replace(found, agent_runs=MIN_RANKED_SEEDS - 5)
    assert (
        _phrase("reading(c)", c=few)
        == f"{reading}; provisional: `{WINNER}` ({MIN_RANKED_SEEDS - 5} training seeds)"
    )
    flow_truth = expected.replace("the winner", "flow").replace("`bee_ttc`", "truth")
    assert _phrase('verdict(c, "flow", "truth")', c=found) == flow_truth


@pytest.mark.parametrize(
    ("call", "expected"),
    [
        ("lr(0.0003)", "3e-4"),
        ("seed_list([2, 0, 1])", "0-2"),
        ("seed_list([0, 2, 3])", "0,2,3"),
        ("seed_list([4])", "4"),
        (
            'randomized({"randomize": {"forward_speed": [0.5, 2.0], "brightness": [0.5, 1.5]}})',
            "speeds 0.5–2 m/s and brightness 0.5–1.5",
        ),
        ('randomized({"randomize": {"obstacle_density": [0.06, 0.18]}})', "densities 0.06–0.18"),
        ("randomized({})", ""),
    ],
)
def test_a_training_config_is_worded_from_its_values(call: str, expected: str) -> None:
    assert _phrase(call, macros="benchmark_tables.j2") == expected


def test_the_picks_standing_and_stage_verdicts_are_worded_from_the_intervals() -> None:
    rises = [
        {"condition": "density 0.18", "rise": 0.07, "low": 0.02, "high": 0.11},
        {"condition": "speed 1.5 m/s", "rise": 0.12, "low": 0.05, "high": 0.2},
    ]
    assert _phrase("standing(r, 0.1)", r=rises) == (
        "stays within +0.10 of its clean rate by point estimate only at density 0.18; it misses that limit at "
        "speed 1.5 m/s"
    )
    assert _phrase("standing(r, 0.1)", r=[{**rises[0], "high": 0.09}]) == (
        "stays within +0.10 of its clean rate with its whole interval at density 0.18"
    )
    less, none = {"low": -0.09, "high": -0.02}, {"low": -0.04, "high": 0.02}
    assert _phrase("stage_verdict(f)", f=[less, less]) == "fails less under every condition"
    assert _phrase("stage_verdict(f)", f=[none]) == "shows no difference under any condition"
    assert _phrase("stage_verdict(f)", f=[less, none]) == "differs under some conditions only"


def _layouts_failed(count: int, runs: int = 1, layouts: int = 300) -> np.ndarray:
    """``runs`` runs that each fail the first ``count`` of ``layouts`` layouts."""
    matrix = np.zeros((runs, layouts))
    matrix[:, :count] = 1.0
    return matrix


@pytest.mark.parametrize(("winner_failures", "fails_less"), [(60, "bee_ttc"), (0, WINNER), (30, None)])
def test_the_best_agents_are_compared_by_a_paired_test(winner_failures: int, fails_less: str | None) -> None:
    failures = {
        "bee_robust": _layouts_failed(45),
        "bee_ttc": _layouts_failed(30),
        "ppo_flow": _layouts_failed(90, runs=5),
        "ppo_oracle": _layouts_failed(0, runs=5),  # privileged: never the best learned agent
        WINNER: _layouts_failed(winner_failures, runs=5),
    }
    rows = [{"agent": a, "failure_rate": m.mean(), "runs": m.shape[0]} for a, m in failures.items()]
    data = SimpleNamespace(leaderboard=rows, failures=failures)
    best_reactive, best_learned = BenchmarkData.best_agents(data)
    assert (best_reactive["agent"], best_learned["agent"]) == ("bee_ttc", WINNER)
    found = BenchmarkData.compare(data, WINNER, "bee_ttc")
    assert found.difference == pytest.approx((winner_failures - 30) / 300) and found.fails_less == fails_less


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


# The lists a template words differently when empty.
BRANCHING_LISTS = ("first_target_met", "validation_within", "pick_rises")


def _variants(name: str, value: Any) -> list[Any]:
    """``value`` as each other branch it steers would need it."""
    if isinstance(value, Comparison):
        return [
            dataclasses.replace(value, low=low, high=high)
            for low, high in ((-0.2, -0.1), (0.1, 0.2), (-0.1, 0.1))
        ]
    if isinstance(value, bool):
        return [not value]
    if name.endswith("table") or name in BRANCHING_LISTS:
        return [value[:0]]
    return []


@pytest.mark.slow
@pytest.mark.parametrize("template", TEMPLATES)
def test_every_template_renders_every_branch_from_the_committed_values(template: str) -> None:
    values = flow_gap_values(RESULTS_DIR, generated="today", command="test")
    texts = {render_report(template, values)}
    for name, value in template_fields(values).items():
        for variant in _variants(name, value):
            texts.add(render_report(template, dataclasses.replace(values, **{name: variant})))
    assert len(texts) > 1 and all(
        "{{" not in text and "{%" not in text and "overlap" not in text for text in texts
    )


@pytest.mark.slow
def test_the_committed_comparisons_are_paired_tests_on_the_leading_tables_layouts() -> None:
    data = load_benchmark_data(RESULTS_DIR)
    assert data.failures[WINNER].shape == (5, len(data.layouts))
    found = data.compare(WINNER, "bee_ttc")
    assert found.difference == pytest.approx(
        data.row(WINNER)["failure_rate"] - data.row("bee_ttc")["failure_rate"]
    )
    values = report_values(data)
    assert values.winner_vs_ttc == found and values.flow_vs_oracle == data.compare("ppo_flow", "ppo_oracle")
    twin = choices().truth_recipe
    others = [r for r in data.leaderboard if r["agent"] != twin]
    assert report_values(dataclasses.replace(data, leaderboard=others)).truth_recipe_flown is False


@pytest.mark.slow
def test_the_readme_says_whether_the_suite_is_flown_whole() -> None:
    values = report_values(load_benchmark_data(RESULTS_DIR))
    whole, partial = (
        render_report("readme_results.md.j2", dataclasses.replace(values, suite_complete=flown))
        for flown in (True, False)
    )
    assert "every agent over all its training seeds on\nevery tier. Its top groups are the agents" in whole
    assert "under way" not in whole and "so far" not in whole
    assert "its flights are under way, and the page lists what is left." in partial
    assert "Its top groups so far, over the agents flown on the whole tier, are the agents no" in partial
