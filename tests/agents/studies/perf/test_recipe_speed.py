"""``flownav bench recipe``: the work a seed of each stage does, counted from its config; whole recipes timed
side by side into ``training_performance.md``; bad recipes refused in one line."""

from __future__ import annotations

from pathlib import Path

import pytest
from helpers import SMALL, tiny_train_config

from agents.common.jinja_reports import render
from agents.common.yaml_config import load_config
from agents.policies.teachers import make_teacher
from agents.studies.perf.recipe_speed import block_ratios, measure_stage, stage_minutes, stage_work
from agents.studies.perf.recipe_speed_report import (
    RecipeTarget,
    parse_recipe,
    recipe_report_values,
    run_recipe_benchmark,
)
from agents.studies.perf.report_kit import RunFacts
from agents.training.train_config import TrainConfig

EXPERIMENTS = Path(__file__).resolve().parents[4] / "configs" / "experiments"


def test_the_winners_second_stage_counts_its_rounded_steps_and_evaluations() -> None:
    config = load_config(EXPERIMENTS / "ppo_flow_course_approach_curriculum_slow.yaml", TrainConfig)
    # 200,000 steps in rollouts of 1024 x 2 -> 98 rollouts; an evaluation every 25,000 // 2 vector steps
    assert stage_work(config) == {
        "ppo_steps": 200_704,
        "evaluations": 8,
        "evaluation_episodes": 80,
        "teacher_env_steps": 0,
        "fitted_state_epochs": 0,
    }


def test_a_teacher_start_counts_its_env_steps_and_its_growing_fits() -> None:
    config = load_config(EXPERIMENTS / "ppo_flow_teacher.yaml", TrainConfig)
    rounds, per_round = config.imitation.rounds, config.imitation.steps_per_round * config.n_envs
    work = stage_work(config)
    assert work["teacher_env_steps"] == rounds * per_round
    # after round r the fit goes over (r + 1) rounds of states, epochs times
    assert work["fitted_state_epochs"] == config.imitation.epochs * per_round * sum(range(1, rounds + 1))


def test_minutes_are_counts_times_measured_seconds() -> None:
    work = {"ppo_steps": 600, "evaluation_episodes": 4, "teacher_env_steps": 60, "fitted_state_epochs": 120}
    measured = {
        "startup_s": 6.0,
        "ppo_s_per_step": 0.01,
        "evaluation_s_per_episode": 3.0,
        "teacher_s_per_step": 0.1,
        "fit_s_per_state_epoch": 0.05,
    }
    assert stage_minutes(work, measured) == pytest.approx(
        {"startup": 0.1, "ppo": 0.1, "evaluation": 0.2, "teacher": 0.2}
    )


def test_ratios_are_taken_block_by_block() -> None:
    results = {"old": [{"total": 10.0}, {"total": 20.0}], "new": [{"total": 4.0}, {"total": 5.0}]}
    assert block_ratios(results, "old") == {"old": [1.0, 1.0], "new": [0.4, 0.25]}


def test_two_tiny_recipes_are_timed_side_by_side_into_the_report(tmp_path: Path) -> None:
    _, old = tiny_train_config(tmp_path, total=128, name="tiny_old")
    _, new = tiny_train_config(
        tmp_path,
        total=64,
        name="tiny_new",
        env={**SMALL, "observe_unresolved": True},
        imitation={"teacher": "bee_ttc", "rounds": 2, "steps_per_round": 16, "epochs": 1},
    )
    paths = run_recipe_benchmark(
        [f"old={old}", str(new)], 1, 1, tmp_path / "out", make_teacher=make_teacher, progress=False
    )
    text = paths[0].read_text()
    assert "| old | 128 | 0 |" in text and "| tiny_new | 64 | 32 |" in text
    assert "1.00 [1.00–1.00]" in text and "this page states no quality" in text
    assert "- `tiny_new`: " in text and "min per seed → **within**" in text
    assert all(path.is_file() for path in paths)


def test_a_privileged_teacher_is_timed_on_envs_that_give_it_the_layout(tmp_path: Path) -> None:
    # The planner reads the layout: the stage's training envs carry its opt-in, as training builds them.
    config, _ = tiny_train_config(
        tmp_path,
        total=64,
        name="tiny_student",
        imitation={"teacher": "planner", "rounds": 1, "steps_per_round": 8, "epochs": 1},
    )
    measured = measure_stage(config, 1, make_teacher, teacher_steps=8)
    assert measured["teacher_s_per_step"] > 0.0 and measured["fit_s_per_state_epoch"] > 0.0


def test_a_recipe_without_a_config_is_refused() -> None:
    with pytest.raises(
        ValueError, match=r"--recipe must be \[name=\]stage.yaml\[,stage.yaml...\], got 'fast='"
    ):
        parse_recipe("fast=")


def test_one_recipe_alone_is_refused(tmp_path: Path) -> None:
    _, old = tiny_train_config(tmp_path, total=64, name="tiny_old")
    with pytest.raises(ValueError, match=r"give at least two recipes to compare, got 1"):
        run_recipe_benchmark([str(old)], 1, 1, tmp_path / "out", progress=False)


def recipe_row(name: str, ratio: float, meets: bool | str, teacher_steps: int) -> dict:
    return {
        "recipe": name,
        "ppo_steps": 1000,
        "teacher_env_steps": teacher_steps,
        "evaluation_episodes": 10,
        **{f"minutes_{kind}": 1.0 for kind in ("startup", "ppo", "evaluation", "teacher")},
        "minutes_per_seed": 4.0,
        "ratio_to_reference": ratio,
        "ratio_min": ratio,
        "ratio_max": ratio,
        "ppo_steps_per_s": 100.0,
        **{f"failure_{key}": 0.04 for key in ("clean", "density_018", "15_m/s")},
        "seeds_clean": 5,
        "meets_quality": meets,
    }


@pytest.mark.parametrize(
    ("ratio", "meets", "verdict"),
    [
        (0.30, True, "meets the validation bar → **met**"),
        (0.40, True, "meets the validation bar → **missed**"),
        (0.30, False, "misses the validation bar → **missed**"),
        (0.30, "", "has not been flown against the validation bar → **missed**"),
    ],
)
def test_the_target_needs_both_a_third_of_the_time_and_the_quality(ratio, meets, verdict) -> None:
    rows = [recipe_row("old", 1.0, True, 0), recipe_row("new", ratio, meets, 10)]
    values = recipe_report_values(rows, 3, RunFacts("flownav bench recipe", 60.0, "now", "-", 2, True))
    assert values.targets == [
        RecipeTarget(
            recipe="new",
            ratio=f"{ratio:.2f}",
            meets=None if meets == "" else meets,
            met=verdict.endswith("**met**"),
        )
    ]
    report = render("agents.studies.perf", "training_performance.md.j2", values, every_value_used=True)
    assert (
        f"- `new`: {ratio:.2f}× the minutes per seed of `old` (target ≤ 0.33×), and it {verdict}." in report
    )
    assert "Recipes with a teacher here: `new`." in report


def test_recipes_never_flown_on_the_lever_conditions_are_judged_by_the_seed_budget_alone() -> None:
    slow = {**recipe_row("slow", 4.0, "", 10), "minutes_per_seed": 16.0}
    rows = [recipe_row("old", 1.0, "", 0), recipe_row("new", 0.5, "", 10), slow]
    values = recipe_report_values(rows, 3, RunFacts("flownav bench recipe", 60.0, "now", "-", 2, True))
    report = render("agents.studies.perf", "training_performance.md.j2", values, every_value_used=True)
    assert "## Quality on the validation layouts" not in report
    assert "target ≤ 0.33×" not in report
    assert "this page states no quality and no time ratio target" in report
    assert "- `new`: 4.0 min per seed → **within**" in report
    assert "- `slow`: 16.0 min per seed → **over**" in report
