"""The benchmark report and the README's results block: the claim wording on small synthetic tables, the marker
blocks, a missing input, and (slow: minutes of bootstraps) the committed outputs being exactly what the writers
make of the committed data."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from agents.common.locations import REPO_ROOT, RESULTS_DIR
from agents.studies.benchmark_claims import agents_broken_by, breaks_phrase, every_or_all_but
from agents.studies.benchmark_data import INPUTS
from agents.studies.benchmark_report import (
    BENCHMARK_TEMPLATE,
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
    # a row failing like the winner reads as overlapping it
    twin = {**data.row(WINNER), "agent": WINNER_ON_TRUE_DEPTHS}
    values = reactive_gap_values(dataclasses.replace(data, leaderboard=[*others, twin]))
    assert values["truth_recipe_flown"] is True and values["fail_truth_recipe"] == values["fail_winner"]
    assert values["winner_vs_truth_recipe"] == "intervals overlapping"
