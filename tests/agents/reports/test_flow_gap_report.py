"""What flow costs a learned policy: the paired gap, its wording, and the flights it is read from."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from agents.analysis.csv_file import LEGACY_FIELDS
from agents.analysis.paired import compare
from agents.analysis.validation_rows import ConfirmationResult, PairedDifference, Rise, SearchRecord
from agents.common.seeds import CONFIRMATION_SEED_START, suite_seeds
from agents.evaluation.suite import SUITE_RESULTS_FOLDERS
from agents.reports.flow_gap_report import (
    READ_SUITE_VERSION,
    confirmation_rows,
    gap,
    gap_row,
    gap_table,
    plot_gap,
    selection_values,
    suite_matrices,
)
from agents.studies.confirmation import COMPARED, PICK, TRUE_DEPTH_RECIPE, run_confirmation


def _write_episodes(path: Path, episodes: list[tuple[str, str, float, int, bool]]) -> None:
    """An episodes CSV in the format from before identities, so its rows match any task's settings."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("a", newline="") as handle:
        writer = csv.writer(handle)
        if path.stat().st_size == 0:
            writer.writerow(LEGACY_FIELDS)
        for agent, factor, level, seed, failed in episodes:
            writer.writerow(
                [agent, factor, level, seed, failed, not failed, False, False, 20.0, 20.0, 200, 0.5, 20.4, 100.0,
                 0.05, 1.0]
            )  # fmt: skip


def _ship(policies: Path, agent: str, seeds: int) -> None:
    (policies / agent).mkdir(parents=True, exist_ok=True)
    for seed in range(seeds):
        (policies / agent / f"seed_{seed}.zip").write_bytes(agent.encode() + bytes([seed]))


@pytest.mark.parametrize(
    ("extra_flow", "extra_truth", "reading"),
    [
        (30, 0, "truth fails less than flow"),
        (0, 30, "flow fails less than truth"),
        (0, 0, "no difference shown"),
    ],
)
def test_a_gap_is_the_paired_test_and_read_from_its_interval(
    extra_flow: int, extra_truth: int, reading: str
) -> None:
    rng = np.random.default_rng(0)
    shared = (rng.random((5, 200)) < 0.05).astype(float)
    flow, truth = shared.copy(), shared.copy()
    flow[:, 100 : 100 + extra_flow] = 1.0
    truth[:, 100 : 100 + extra_truth] = 1.0
    found = gap(flow, truth)
    assert found == compare("flow", flow, "truth", truth)  # paired.py's test, not a second bootstrap
    assert found.difference == pytest.approx(flow.mean() - truth.mean())
    assert gap_row("clean", flow, truth)[3:] == [
        f"{found.difference:+.3f} [{found.low:+.3f}, {found.high:+.3f}]",
        reading,
    ]


def test_a_gap_row_pairs_the_layouts_both_recipes_flew() -> None:
    rng = np.random.default_rng(0)
    truth = (rng.random((5, 200)) < 0.05).astype(float)
    flow = truth.copy()
    flow[:, :30] = 1.0  # flow fails thirty more layouts with every seed
    label, flow_cell, truth_cell, difference, reading = gap_row("clean", flow, truth)
    assert label == "clean"
    expected = flow.mean() - truth.mean()
    assert difference.startswith(f"{expected:+.3f} [") and reading == "truth fails less than flow"
    assert flow_cell.startswith(f"{flow.mean():.2f} [") and truth_cell.startswith(f"{truth.mean():.2f} [")


def test_suite_matrices_keep_only_tiers_every_seed_flew_whole(tmp_path: Path) -> None:
    policies = tmp_path / "policies"
    _ship(policies, "ppo_flow", 2)
    layouts = list(suite_seeds(version=READ_SUITE_VERSION))
    episodes = [(f"ppo_flow@{k}", "clean", 0.0, seed, seed % 10 == 0) for seed in layouts for k in range(2)]
    episodes += [(f"ppo_flow@{k}", "hard", 0.0, seed, True) for seed in layouts[:-1] for k in range(2)]
    episodes += [("bee", "noisy", 0.0, seed, False) for seed in layouts]
    _write_episodes(tmp_path / SUITE_RESULTS_FOLDERS[READ_SUITE_VERSION] / "suite_episodes.csv", episodes)
    found = suite_matrices(tmp_path, "ppo_flow", policies)
    assert list(found) == ["clean"]
    assert found["clean"].shape == (2, len(layouts)) and found["clean"].mean() == pytest.approx(0.1)
    assert suite_matrices(tmp_path, "ppo_oracle", policies) == {}


def test_the_students_gap_per_tier_sets_the_planners_failure_beside_it(tmp_path: Path) -> None:
    policies = tmp_path / "policies"
    student, twin = "ppo_flow_planner_student", "ppo_flow_planner_student_oracle"
    for agent in (student, twin):
        _ship(policies, agent, 2)
    layouts = list(suite_seeds(version=READ_SUITE_VERSION))
    episodes = []
    for tier in ("clean", "hard"):
        episodes += [(f"{student}@{k}", tier, 0.0, seed, seed % 5 == 0) for seed in layouts for k in range(2)]
        episodes += [(f"{twin}@{k}", tier, 0.0, seed, seed % 10 == 0) for seed in layouts for k in range(2)]
    episodes += [("planner", "clean", 0.0, seed, seed % 100 == 0) for seed in layouts]
    _write_episodes(tmp_path / SUITE_RESULTS_FOLDERS[READ_SUITE_VERSION] / "suite_episodes.csv", episodes)
    planner = suite_matrices(tmp_path, "planner", policies)
    assert list(planner) == ["clean"] and planner["clean"].shape == (1, len(layouts))
    rows = [
        (tier, *[suite_matrices(tmp_path, a, policies)[tier] for a in (student, twin)])
        for tier in ("clean", "hard")
    ]
    table = gap_table(student, twin, rows, "tier", ceiling=planner).splitlines()
    assert table[0].endswith("| `planner` (the ceiling) |")
    assert table[2].startswith("| clean | 0.20 [") and f"| {planner['clean'].mean():.2f} [" in table[2]
    assert "truth fails less than flow" in table[2]
    assert table[3].startswith("| hard |") and table[3].endswith("| not flown |")
    assert gap_table(student, twin, [], "tier", ceiling=planner) == ""


def test_the_true_depth_gap_is_read_from_the_confirmation_flights(tmp_path: Path) -> None:
    policies, flights = tmp_path / "policies", tmp_path / "confirmation"
    for agent in (PICK, *COMPARED, TRUE_DEPTH_RECIPE):
        _ship(policies, agent, 2)
    layouts = range(CONFIRMATION_SEED_START, CONFIRMATION_SEED_START + 40)
    conditions = (("clean", 0.0), ("obstacle_density", 0.18), ("forward_speed", 1.5))
    for agent, every in ((PICK, 4), (COMPARED[0], 5), (COMPARED[1], 6), (TRUE_DEPTH_RECIPE, 1_000)):
        episodes = [
            (f"ppo_flow@{k}", factor, level, seed, seed % every == 0)
            for factor, level in conditions
            for seed in layouts
            for k in range(2)
        ]
        _write_episodes(flights / f"{agent}.csv", episodes)
    result = run_confirmation(flights, layouts=40, report_only=True, policies_dir=policies)
    rows = confirmation_rows(result, tmp_path, policies)
    assert [where for where, *_ in rows] == ["clean", "density 0.18", "speed 1.5 m/s"]
    assert gap_table(PICK, TRUE_DEPTH_RECIPE, rows, "condition").count("truth fails less than flow") == 3
    assert gap(*rows[0][1:]).difference == pytest.approx(0.25 - 0.025)

    (flights / f"{TRUE_DEPTH_RECIPE}.csv").unlink()
    result = run_confirmation(flights, layouts=40, report_only=True, policies_dir=policies)
    assert confirmation_rows(result, tmp_path, policies) == []
    assert gap_table(PICK, TRUE_DEPTH_RECIPE, [], "condition") == ""


def test_the_selection_keeps_the_picks_rises_and_each_stages_differences() -> None:
    result = ConfirmationResult(
        layouts=200,
        rates=[],
        differences=[
            PairedDifference("clean", COMPARED[0], -0.01, -0.04, 0.02),
            PairedDifference("clean", COMPARED[1], -0.06, -0.09, -0.02),
        ],
        rises=[
            Rise("density 0.18", PICK, 0.07, 0.02, 0.11),
            Rise("speed 1.5 m/s", "ppo_flow", 0.01, -0.02, 0.04),
        ],
    )
    search = SearchRecord(configs=["a", "b", "c"], layouts=[900_000, 900_049], differences=[])
    values = selection_values(result, search)
    assert values.pick_rises == result.rises[:1] and values.search == search
    assert {k: [d.difference for d in found] for k, found in values.stages.items()} == {
        COMPARED[0]: [-0.01],
        COMPARED[1]: [-0.06],
    }


def test_the_figure_draws_each_recipe_where_it_flew(tmp_path: Path) -> None:
    panels = {
        "plain": [("test, clean", (0.08, 0.06, 0.12), (0.10, 0.05, 0.15))],
        "pick": [("clean", (0.03, 0.02, 0.05), None), ("hard", (0.4, 0.3, 0.5), None)],
    }
    plot_gap(panels, tmp_path / "flow_gap.png")
    assert (tmp_path / "flow_gap.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
