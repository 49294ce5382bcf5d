"""``results/training_performance.md``: recipes' minutes per seed measured side by side
(:mod:`agents.studies.perf.recipe_speed`), beside the quality each reaches on the validation layouts
(``flownav ablation``'s runs) and the minutes their own training records say."""

from __future__ import annotations

import json
import statistics
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from agents.common.locations import POLICIES_DIR
from agents.common.machine import available_cores
from agents.common.tables import markdown_table, today, write_csv
from agents.common.yaml_config import load_config
from agents.studies.confirmation import ALLOWED_RISE, seed_failure_matrix
from agents.studies.perf.recipe_speed import (
    Recipe,
    block_ratios,
    measure_recipes,
    median_minutes,
    stage_work,
)
from agents.training.train_config import TrainConfig

# The validation quality a faster recipe must reach: the bar the lever search's winner met.
CLEAN_FAILURE_BAR = 0.05
# The time-to-policy goal: a recipe in at most a third of the reference's minutes per seed.
TARGET_TIME_RATIO = 1 / 3
# flownav ablation's folders per condition, under its --out (results/ablation).
CONDITIONS = {"clean": "", "density 0.18": "density_0.18", "1.5 m/s": "speed_1.5"}
KINDS = ("startup", "ppo", "evaluation", "teacher")


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


def quality(recipe: Recipe, ablation_dir: Path) -> dict[str, Any]:
    """The recipe's last stage on the validation layouts, per condition: failure over runs × layouts, the
    number of seeds, and whether it meets the bar (clean ≤ 0.05, each condition ≤ clean + 0.10); None
    entries where ``flownav ablation`` has not flown it."""
    name = recipe.stages[-1].name
    rates: dict[str, Any] = {}
    for label, folder in CONDITIONS.items():
        matrix = seed_failure_matrix(ablation_dir / folder / name)
        rates[label] = None if matrix is None else (float(matrix.mean()), len(matrix), matrix.shape[1])
    clean = rates["clean"]
    meets = None
    if all(rate is not None for rate in rates.values()):
        meets = clean[0] <= CLEAN_FAILURE_BAR and all(
            rates[label][0] <= clean[0] + ALLOWED_RISE for label in CONDITIONS if label != "clean"
        )
    return {"rates": rates, "meets": meets}


def recorded_minutes(recipe: Recipe, runs_dir: Path, policies_dir: Path = POLICIES_DIR) -> list[float]:
    """Minutes per seed the recipe's training records say (the last stage's, with its earlier stage's when it
    started from one): run folders first, else shipped records. Each was trained on whatever machine and
    load it met, so these are context, not the measurement."""
    name = recipe.stages[-1].name
    records = sorted((runs_dir / name).glob("seed_*/seed_*.json")) or sorted(
        (policies_dir / name).glob("seed_*.json")
    )
    minutes = []
    for path in records:
        record = json.loads(path.read_text())
        total = record.get("total_wall_minutes_with_init", record.get("total_wall_minutes"))
        if total:
            minutes.append(float(total))
    return minutes


def run_recipe_benchmark(
    recipe_specs: Sequence[str],
    rollouts: int,
    repeats: int,
    out_dir: Path,
    *,
    make_teacher: Any = None,
    ablation_dir: Path = Path("results/ablation"),
    runs_dir: Path = Path("runs"),
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
    rows = []
    for recipe in recipes:
        medians = median_minutes(results[recipe.name])
        work = [stage_work(config) for config in recipe.stages]
        judged = quality(recipe, ablation_dir)
        recorded = recorded_minutes(recipe, runs_dir)
        ppo_rates = [1.0 / s["measured"]["ppo_s_per_step"] for e in results[recipe.name] for s in e["stages"]]
        rows.append(
            {
                "recipe": recipe.name,
                "stages": " → ".join(str(path) for path in recipe.paths),
                "ppo_steps": sum(w["ppo_steps"] for w in work),
                "teacher_env_steps": sum(w["teacher_env_steps"] for w in work),
                "evaluation_episodes": sum(w["evaluation_episodes"] for w in work),
                **{f"minutes_{kind}": round(medians[kind], 2) for kind in KINDS},
                "minutes_per_seed": round(medians["total"], 1),
                "ratio_to_reference": round(statistics.median(ratios[recipe.name]), 3),
                "ratio_min": round(min(ratios[recipe.name]), 3),
                "ratio_max": round(max(ratios[recipe.name]), 3),
                "ppo_steps_per_s": round(statistics.median(ppo_rates), 1),
                "seeds_per_hour_here": round(60.0 / medians["total"], 2),
                **_quality_columns(judged),
                "recorded_minutes_median": round(statistics.median(recorded), 1) if recorded else "",
                "recorded_seeds": len(recorded),
            }
        )
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = [out_dir / f"training_performance.{ext}" for ext in ("md", "csv", "png")]
    write_csv(paths[1], rows)
    _plot(rows, paths[2])
    command = (
        "flownav bench recipe "
        + " ".join(f"--recipe {r.name}={','.join(map(str, r.paths))}" for r in recipes)
        + f" --rollouts {rollouts} --repeats {repeats} --out {out_dir}"
    )
    paths[0].write_text(_report(rows, command, time.perf_counter() - started, repeats))
    return paths


def _quality_columns(judged: dict[str, Any]) -> dict[str, Any]:
    columns: dict[str, Any] = {}
    for label, rate in judged["rates"].items():
        key = label.replace(" ", "_").replace(".", "")
        columns[f"failure_{key}"] = "" if rate is None else round(rate[0], 3)
        columns[f"seeds_{key}"] = "" if rate is None else rate[1]
    columns["meets_quality"] = "" if judged["meets"] is None else judged["meets"]
    return columns


def _plot(rows: list[dict[str, Any]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axis = plt.subplots(figsize=(7, 0.9 + 0.7 * len(rows)))
    left = np.zeros(len(rows))
    names = [row["recipe"] for row in rows]
    for kind in KINDS:
        widths = np.array([row[f"minutes_{kind}"] for row in rows], float)
        axis.barh(names, widths, left=left, label=kind)
        left += widths
    axis.set_xlabel("minutes per training seed (median over alternated blocks)")
    axis.invert_yaxis()
    axis.legend(loc="lower right", fontsize=8)
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def _report(rows: list[dict[str, Any]], command: str, elapsed: float, repeats: int) -> str:
    from agents.studies.perf.timing import hardware_summary

    reference = rows[0]
    table = markdown_table(
        [
            "recipe",
            "PPO steps",
            "teacher steps",
            "eval episodes",
            *(f"min {k}" for k in KINDS),
            "min per seed",
            "× reference [min–max]",
            "PPO steps/s",
        ],
        [
            [
                r["recipe"],
                f"{r['ppo_steps']:,}",
                f"{r['teacher_env_steps']:,}",
                r["evaluation_episodes"],
                *(r[f"minutes_{k}"] for k in KINDS),
                r["minutes_per_seed"],
                f"{r['ratio_to_reference']:.2f} [{r['ratio_min']:.2f}–{r['ratio_max']:.2f}]",
                r["ppo_steps_per_s"],
            ]
            for r in rows
        ],
    )
    quality_table = markdown_table(
        [
            "recipe",
            "clean",
            "density 0.18",
            "1.5 m/s",
            "seeds",
            "meets the bar",
            "recorded min per seed (median, seeds)",
        ],
        [
            [
                r["recipe"],
                _rate(r["failure_clean"]),
                _rate(r["failure_density_018"]),
                _rate(r["failure_15_m/s"]),
                r["seeds_clean"],
                {True: "yes", False: "no", "": "not flown"}[r["meets_quality"]],
                f"{r['recorded_minutes_median']} ({r['recorded_seeds']})" if r["recorded_seeds"] else "-",
            ]
            for r in rows
        ],
    )
    cores = available_cores()
    lines = [
        "# Time to a policy: minutes per training seed, recipes side by side",
        "",
        f"Generated {today()} by `{command}` in {elapsed / 60:.1f} min.",
        "",
        hardware_summary(),
        "",
        "## Minutes per seed (measured in one sitting, alternated)",
        "",
        table,
        "",
        f"Each recipe's stages were built as training builds them (worker processes for n_envs > 1), and each kind "
        f"of work was timed on them: a few PPO rollouts, one held-out evaluation, one teacher round and fit. "
        f"Minutes per seed are the config's counts times those seconds (`agents/studies/perf/recipe_speed.py`). "
        f"The recipes alternated block by block, {repeats} times; the ratio to `{reference['recipe']}` is taken per "
        f"block, then the median (min–max over blocks). 'startup' is building the envs and model and a warm-up "
        f"rollout, once per stage.",
        "",
        "![minutes per seed by kind of work](training_performance.png)",
        "",
        "## Quality on the validation layouts",
        "",
        quality_table,
        "",
        f"Failure over runs × layouts of `flownav ablation` on validation layouts (clean: 900,000–900,099; the "
        f"conditions: 900,000–900,049), the recipe's last stage, every seed it has. The bar: clean ≤ "
        f"{CLEAN_FAILURE_BAR:.2f} and each condition at most +{ALLOWED_RISE:.2f} over clean, by point estimate, "
        "as the lever search's winner was picked. Recorded minutes are the seeds' own training records (with the "
        "earlier stage's): trained on whatever machine and load they met, so context, not the comparison.",
        "",
        "## Target",
        "",
        *_target_lines(rows),
        "",
        "## Seeds per hour",
        "",
        f"Here ({cores} cores, one seed's envs on all of them): "
        + "; ".join(f"`{r['recipe']}` {r['seeds_per_hour_here']:.2f}" for r in rows)
        + f". A 16-core machine trains seeds side by side (`flownav train --seeds --parallel`, or `--backend ray`), "
        f"each on {cores} cores as here: an estimate from the per-core rate, not a measurement, is "
        + "; ".join(f"`{r['recipe']}` {r['seeds_per_hour_here'] * 16 / cores:.1f}" for r in rows)
        + " seeds per hour, if rendering (software, on the CPU) scales with cores as it does here.",
        "",
    ]
    return "\n".join(lines)


def _target_lines(rows: list[dict[str, Any]]) -> list[str]:
    """The time-to-policy target, worded from the data: a recipe at ≤ 1/3 of the reference's minutes per seed that
    meets the reference's validation bar."""
    reference = rows[0]
    lines = []
    for row in rows[1:]:
        fast = row["ratio_to_reference"] <= TARGET_TIME_RATIO
        judged = {True: "meets", False: "misses", "": "has not been flown against"}[row["meets_quality"]]
        met = fast and row["meets_quality"] is True
        lines.append(
            f"- `{row['recipe']}`: {row['ratio_to_reference']:.2f}× the minutes per seed of `{reference['recipe']}` "
            f"(target ≤ {TARGET_TIME_RATIO:.2f}×), and it {judged} the validation bar → **{'met' if met else 'missed'}**."
        )
    teachers = [row["recipe"] for row in rows if row["teacher_env_steps"]]
    if teachers:
        lines += [
            "",
            "A teacher start counts only its own work per seed: the teacher rule's gains were tuned once for the "
            "benchmark (`flownav tune`, `results/tuning/`), not per seed, and the student starts from what that "
            "rule does, so it needs a rule worth imitating on the task; its PPO stage is what may carry it past "
            "the rule. Recipes with a teacher here: " + ", ".join(f"`{name}`" for name in teachers) + ".",
        ]
    return lines


def _rate(value: Any) -> str:
    return "-" if value == "" else f"{value:.2f}"
