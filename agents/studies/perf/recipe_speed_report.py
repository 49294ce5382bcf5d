"""``results/training_performance.md``: recipes' minutes per seed measured side by side
(:mod:`agents.studies.perf.recipe_speed`), beside the quality each reaches on the validation layouts
(``flownav ablation``'s runs)."""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from agents.analysis.perf_rows import RecipeBlock, RecipeQuality
from agents.common.seeds import ABLATION_SEED_START
from agents.common.tables import write_csv
from agents.common.yaml_config import load_config
from agents.studies.benchmark_data import seed_failures
from agents.studies.confirmation import ALLOWED_RISE
from agents.studies.perf.recipe_speed import (
    KINDS,
    Recipe,
    TeacherFactory,
    block_ratios,
    measure_recipes,
    median_minutes,
    stage_work,
)
from agents.studies.perf.report_kit import RunFacts, interval, median, saved_figure, table, write_report
from agents.training.train_config import TrainConfig

# The validation quality a faster recipe must reach: the bar the lever search's winner met.
CLEAN_FAILURE_BAR = 0.05
# The time-to-policy goal: a recipe in at most a third of the reference's minutes per seed.
TARGET_TIME_RATIO = 1 / 3
# The budget a recipe's seed must fit: a quarter of an hour on the benchmark's 2-core machine, so that a
# researcher can train the 10 seeds a ranked agent needs in an afternoon.
SEED_BUDGET_MINUTES = 15.0
# flownav ablation's folders per condition, under its --out (results/ablation).
CONDITIONS = {"clean": "", "density 0.18": "density_0.18", "1.5 m/s": "speed_1.5"}
# Validation layouts flownav ablation flies per seed: clean, and under each condition.
ABLATION_LAYOUTS = {"clean": 100, "conditions": 50}


def parse_recipe(text: str) -> Recipe:
    """``name=stage1.yaml,stage2.yaml`` (or just ``stage.yaml``, named after it) as a :class:`Recipe`.

    Raises:
        ValueError: no config path; a config that does not load names its file and key.
    """
    name, _, paths = text.rpartition("=")
    files = tuple(Path(p) for p in paths.split(",") if p)
    if not files:
        raise ValueError(f"--recipe must be [name=]stage.yaml[,stage.yaml...], got {text!r}")
    stages = tuple(load_config(path, TrainConfig) for path in files)
    return Recipe(name or stages[-1].name, stages, files)


def quality(recipe: Recipe, ablation_dir: Path) -> RecipeQuality:
    """The recipe's last stage on the validation layouts, per condition: failure over runs × layouts, the
    number of seeds, and whether it meets the bar (clean ≤ 0.05, each condition ≤ clean + 0.10); None
    entries where ``flownav ablation`` has not flown it."""
    name = recipe.stages[-1].name
    matrices = {label: seed_failures(ablation_dir / folder / name) for label, folder in CONDITIONS.items()}
    rates = {label: None if m is None else (float(m.mean()), len(m)) for label, m in matrices.items()}
    failures = [rate[0] for rate in rates.values() if rate is not None]
    meets = None
    if len(failures) == len(rates):  # clean first: the conditions may rise at most ALLOWED_RISE over it
        meets = failures[0] <= CLEAN_FAILURE_BAR and max(failures) <= failures[0] + ALLOWED_RISE
    return RecipeQuality(rates=rates, meets=meets)


def run_recipe_benchmark(
    recipe_specs: Sequence[str],
    rollouts: int,
    repeats: int,
    out_dir: Path,
    *,
    make_teacher: TeacherFactory | None = None,
    ablation_dir: Path = Path("results/ablation"),
    progress: bool = True,
) -> list[Path]:
    """Measure the recipes side by side and write ``training_performance.md``, ``.csv`` and ``.png`` to
    ``out_dir``; the first recipe is the reference the others are compared with. Returns the paths.

    Raises:
        ValueError: a bad recipe, count, or fewer than two recipes.
    """
    recipes = [parse_recipe(spec) for spec in recipe_specs]
    started = time.perf_counter()
    results = measure_recipes(recipes, rollouts, repeats, make_teacher, progress)
    ratios = block_ratios(results, recipes[0].name)
    rows = [
        _recipe_row(recipe, results[recipe.name], ratios[recipe.name], ablation_dir) for recipe in recipes
    ]
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = [out_dir / f"training_performance.{ext}" for ext in ("md", "csv", "png")]
    write_csv(paths[1], rows)
    _plot(rows, paths[2])
    command = (
        "flownav bench recipe "
        + " ".join(f"--recipe {r.name}={','.join(map(str, r.paths))}" for r in recipes)
        + f" --rollouts {rollouts} --repeats {repeats} --out {out_dir}"
    )
    values = recipe_report_values(rows, repeats, RunFacts.of_this_run(command, started))
    write_report(paths[0], "training_performance.md.j2", values)
    return paths


def _recipe_row(
    recipe: Recipe, entries: Sequence[RecipeBlock], ratios: list[float], ablation_dir: Path
) -> dict[str, float | str]:
    """One recipe's CSV row: its work per seed, measured minutes, ratio to the reference and validation
    quality."""
    medians = median_minutes(entries)
    work = [stage_work(config) for config in recipe.stages]
    ppo_rates = [1.0 / s["measured"]["ppo_s_per_step"] for e in entries for s in e["stages"]]
    ratio = interval("ratio_to_reference", ratios, "ratio")
    return {
        "recipe": recipe.name,
        "stages": " → ".join(str(path) for path in recipe.paths),
        "ppo_steps": sum(w["ppo_steps"] for w in work),
        "teacher_env_steps": sum(w["teacher_env_steps"] for w in work),
        "evaluation_episodes": sum(w["evaluation_episodes"] for w in work),
        **{f"minutes_{kind}": round(medians[kind], 2) for kind in KINDS},
        "minutes_per_seed": round(medians["total"], 1),
        **{key: round(value, 3) for key, value in ratio.items()},
        "ppo_steps_per_s": round(median(ppo_rates), 1),
        **_quality_columns(quality(recipe, ablation_dir)),
    }


def _quality_columns(judged: RecipeQuality) -> dict[str, float | str]:
    columns: dict[str, float | str] = {}
    for label, rate in judged["rates"].items():
        key = label.replace(" ", "_").replace(".", "")
        columns[f"failure_{key}"] = "" if rate is None else round(rate[0], 3)
        columns[f"seeds_{key}"] = "" if rate is None else rate[1]
    columns["meets_quality"] = "" if judged["meets"] is None else judged["meets"]
    return columns


def _plot(rows: Sequence[Mapping[str, object]], path: Path) -> None:
    with saved_figure(path, (7, 0.9 + 0.7 * len(rows)), dpi=120) as figure:
        axis = figure.subplots()
        left = np.zeros(len(rows))
        names = [str(row["recipe"]) for row in rows]
        for kind in KINDS:
            widths = np.array([row[f"minutes_{kind}"] for row in rows], float)
            axis.barh(names, widths, left=left, label=kind)
            left += widths
        axis.set_xlabel("minutes per training seed (median over alternated blocks)")
        axis.invert_yaxis()
        axis.legend(loc="lower right", fontsize=8)


@dataclass(frozen=True)
class RecipeTarget:
    """The time-to-policy target for one recipe (:func:`_target`): its ratio to the reference's minutes per seed,
    whether it meets the reference's validation bar (None: not flown against it), and whether it meets both."""

    recipe: str
    ratio: str
    meets: bool | None
    met: bool


@dataclass(frozen=True)
class SeedBudget:
    """One recipe's minutes per training seed and whether they fit the seed budget."""

    recipe: str
    minutes: float
    within: bool


@dataclass(frozen=True)
class TrainingPerformanceValues:
    """Every value ``templates/training_performance.md.j2`` words (:func:`recipe_report_values`)."""

    run: RunFacts
    table: str
    repeats: str
    reference: str
    quality_table: str
    clean_layouts: str
    condition_layouts: str
    clean_bar: str
    allowed_rise: str
    target_ratio: str
    targets: list[RecipeTarget]
    quality_flown: bool
    seed_budget: str
    budgets: list[SeedBudget]
    teachers: str


# A row is a CSV row whose columns are named from KINDS and CONDITIONS (``minutes_ppo``, ``failure_clean``): no
# TypedDict spells computed keys, and its numbers are compared and formatted here.
def recipe_report_values(
    rows: Sequence[Mapping[str, Any]], repeats: int, run: RunFacts
) -> TrainingPerformanceValues:
    """Every figure, table and verdict of ``templates/training_performance.md.j2``, from the recipes' rows (the
    reference first, as :func:`run_recipe_benchmark` writes them to the CSV), the number of blocks and the
    run's facts."""
    reference = rows[0]
    times = [
        {**row, "ratio": f"{row['ratio_to_reference']:.2f} [{row['ratio_min']:.2f}–{row['ratio_max']:.2f}]"}
        for row in rows
    ]
    minutes = {
        "recipe": "{recipe}",
        "PPO steps": "{ppo_steps:,}",
        "teacher steps": "{teacher_env_steps:,}",
        "eval episodes": "{evaluation_episodes}",
        **{f"min {kind}": f"{{minutes_{kind}}}" for kind in KINDS},
        "min per seed": "{minutes_per_seed}",
        "× reference [min–max]": "{ratio}",
        "PPO steps/s": "{ppo_steps_per_s}",
    }
    judged = [
        dict(row)
        | {key: _rate(row[f"failure_{key}"]) for key in ("clean", "density_018")}
        | {
            "speed": _rate(row["failure_15_m/s"]),
            "meets": {True: "yes", False: "no", "": "not flown"}[row["meets_quality"]],
        }
        for row in rows
    ]
    quality = {
        "recipe": "{recipe}",
        "clean": "{clean}",
        "density 0.18": "{density_018}",
        "1.5 m/s": "{speed}",
        "seeds": "{seeds_clean}",
        "meets the bar": "{meets}",
    }
    first, clean, conditions = ABLATION_SEED_START, ABLATION_LAYOUTS["clean"], ABLATION_LAYOUTS["conditions"]
    return TrainingPerformanceValues(
        run=run,
        table=table(times, minutes),
        repeats=str(repeats),
        reference=reference["recipe"],
        quality_table=table(judged, quality),
        clean_layouts=f"{first:,}–{first + clean - 1:,}",
        condition_layouts=f"{first:,}–{first + conditions - 1:,}",
        clean_bar=f"{CLEAN_FAILURE_BAR:.2f}",
        allowed_rise=f"{ALLOWED_RISE:.2f}",
        target_ratio=f"{TARGET_TIME_RATIO:.2f}",
        targets=[_target(r["recipe"], r["ratio_to_reference"], r["meets_quality"]) for r in rows[1:]],
        # The quality section and the ratio target read flownav ablation's lever-search conditions: shown only
        # where some recipe was flown there, else every row would say "not flown".
        quality_flown=any(row["meets_quality"] != "" for row in rows),
        seed_budget=f"{SEED_BUDGET_MINUTES:g}",
        budgets=[
            SeedBudget(
                recipe=r["recipe"],
                minutes=r["minutes_per_seed"],
                within=float(r["minutes_per_seed"]) <= SEED_BUDGET_MINUTES,
            )
            for r in rows
        ],
        teachers=", ".join(f"`{row['recipe']}`" for row in rows if row["teacher_env_steps"]),
    )


def _target(recipe: str, ratio: float, meets_quality: bool | str) -> RecipeTarget:
    """The time-to-policy target for one recipe: ``ratio`` (to the reference's minutes per seed) at most a third,
    and the reference's validation bar met (``meets_quality``; "" and None: not flown against it)."""
    meets = None if meets_quality == "" else bool(meets_quality)
    fast = ratio <= TARGET_TIME_RATIO
    return RecipeTarget(recipe=recipe, ratio=f"{ratio:.2f}", meets=meets, met=fast and meets is True)


def _rate(value: float | str) -> str:
    return "-" if value == "" else f"{value:.2f}"
