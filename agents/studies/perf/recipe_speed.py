"""``flownav bench recipe``: minutes per training seed of whole recipes, measured side by side in one sitting
(the time-to-policy target).

A recipe is its stages' training configs in order (a curriculum's first stage, then the stage that starts from
it). A seed of a stage does four kinds of work, each counted from its config:

* PPO steps: ``total_timesteps`` rounded up to whole rollouts (``n_steps × n_envs``), as training rounds them;
* held-out evaluations: one per ``eval_every`` steps, of ``eval_episodes`` episodes each;
* a teacher start (``imitation:``): its env steps, and its fits (epochs over every state recorded so far, after
  each round);
* the envs' and model's start-up, once per stage.

Each kind is timed on the stage's own envs and model, built as training builds them (worker processes for
``n_envs`` > 1), for a few rollouts, one evaluation, one teacher round; the minutes per seed are the counts
times the measured seconds. The recipes are measured in turn, block after block, ``repeats`` times, so a
machine shared with other work slows both alike, and their ratio is taken per block before the median.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from tqdm import tqdm

from agents.analysis.perf_rows import RecipeBlock, StageMeasurement
from agents.studies.perf.report_kit import median
from agents.training.envs import build_envs, close_quietly
from agents.training.imitation import TeacherFactory, fit, fly
from agents.training.ppo import new_model
from agents.training.student_view import privileged_settings
from agents.training.train_config import TrainConfig

# The kinds of work a seed does, each timed on its own.
KINDS = ("startup", "ppo", "evaluation", "teacher")


@dataclasses.dataclass(frozen=True)
class Recipe:
    """A named sequence of stage configs, trained one after the other per seed."""

    name: str
    stages: tuple[TrainConfig, ...]
    paths: tuple[Path, ...]


def stage_work(config: TrainConfig) -> dict[str, int]:
    """What one seed of ``config`` does: PPO steps, evaluations, evaluation episodes, teacher env steps and
    fitted state-epochs."""
    rollout = config.ppo.n_steps * config.n_envs
    ppo_steps = math.ceil(config.total_timesteps / rollout) * rollout
    # SB3's EvalCallback counts calls (one per vector step): it evaluates every eval_every // n_envs of them.
    calls_between = max(1, config.eval_every // config.n_envs)
    evaluations = (ppo_steps // config.n_envs) // calls_between
    imitation = config.imitation
    states_per_round = imitation.steps_per_round * config.n_envs if imitation.teacher else 0
    rounds = imitation.rounds if imitation.teacher else 0
    return {
        "ppo_steps": ppo_steps,
        "evaluations": evaluations,
        "evaluation_episodes": evaluations * config.eval_episodes,
        "teacher_env_steps": rounds * states_per_round,
        "fitted_state_epochs": imitation.epochs * states_per_round * rounds * (rounds + 1) // 2,
    }


def measure_stage(
    config: TrainConfig, rollouts: int, make_teacher: TeacherFactory | None = None, teacher_steps: int = 256
) -> dict[str, float]:
    """Seconds per unit of each kind of work of ``config``'s seed, on envs and a model built as training builds
    them: ``startup_s`` (envs and model, once), ``ppo_s_per_step``, ``evaluation_s_per_episode`` and, with a
    teacher, ``teacher_s_per_step`` (flying the student, labelling with the teacher) and
    ``fit_s_per_state_epoch``."""
    # torch and stable-baselines3 are imported here: they are slow to import and only the measurement needs them.
    import torch
    from stable_baselines3.common.evaluation import evaluate_policy

    torch.set_num_threads(1)
    started = time.perf_counter()
    teacher = None
    if config.imitation.teacher:
        if make_teacher is None:
            raise ValueError(
                f"{config.name} starts from teacher {config.imitation.teacher!r}: give make_teacher"
            )
        teacher = make_teacher(config.imitation.teacher, config.imitation.teacher_params)
    # A privileged teacher's opt-in (the planner's observe_layout) reaches the training envs, as in training.
    envs, eval_env = build_envs(config, teacher_settings=privileged_settings(teacher))
    try:
        model = new_model(config, envs)
        rollout = config.ppo.n_steps * config.n_envs
        model.learn(rollout)  # warm-up: first renders, torch's first passes (counted as start-up)
        measured = {"startup_s": time.perf_counter() - started}
        begun = time.perf_counter()
        model.learn(rollout * rollouts, reset_num_timesteps=False)
        measured["ppo_s_per_step"] = (time.perf_counter() - begun) / (rollout * rollouts)
        begun = time.perf_counter()
        evaluate_policy(model, eval_env, n_eval_episodes=config.eval_episodes, deterministic=True)
        measured["evaluation_s_per_episode"] = (time.perf_counter() - begun) / config.eval_episodes
        if teacher is not None:
            begun = time.perf_counter()
            flights = fly(envs, teacher, teacher_steps, config.ppo.gamma, student=model)
            measured["teacher_s_per_step"] = (time.perf_counter() - begun) / len(flights)
            params = dataclasses.replace(config.imitation, epochs=1)
            begun = time.perf_counter()
            fit(model, flights, params, np.random.default_rng(0))
            measured["fit_s_per_state_epoch"] = (time.perf_counter() - begun) / len(flights)
    finally:
        close_quietly(envs)
        close_quietly(eval_env)
    return measured


def stage_minutes(work: dict[str, int], measured: dict[str, float]) -> dict[str, float]:
    """Minutes per seed of a stage, per kind of work: the counts of :func:`stage_work` times the seconds of
    :func:`measure_stage`."""
    seconds = {
        "startup": measured["startup_s"],
        "ppo": work["ppo_steps"] * measured["ppo_s_per_step"],
        "evaluation": work["evaluation_episodes"] * measured["evaluation_s_per_episode"],
        "teacher": work["teacher_env_steps"] * measured.get("teacher_s_per_step", 0.0)
        + work["fitted_state_epochs"] * measured.get("fit_s_per_state_epoch", 0.0),
    }
    return {kind: value / 60.0 for kind, value in seconds.items()}


def measure_recipes(
    recipes: Sequence[Recipe],
    rollouts: int,
    repeats: int,
    make_teacher: TeacherFactory | None = None,
    progress: bool = True,
) -> dict[str, list[RecipeBlock]]:
    """Every stage of every recipe measured ``repeats`` times, recipes alternating block by block; per recipe,
    one entry per repeat: its minutes per seed by kind of work and in total, and the stages' measurements.

    Raises:
        ValueError: a count below 1, or fewer than two recipes.
    """
    if rollouts < 1 or repeats < 1:
        raise ValueError(f"--rollouts and --repeats must be >= 1, got {rollouts}, {repeats}")
    if len(recipes) < 2:
        raise ValueError(f"give at least two recipes to compare, got {len(recipes)}")
    results: dict[str, list[RecipeBlock]] = {recipe.name: [] for recipe in recipes}
    blocks = [(repeat, recipe) for repeat in range(repeats) for recipe in recipes]
    for _, recipe in tqdm(blocks, desc="bench recipe", unit="recipe", disable=not progress):
        stages: list[StageMeasurement] = []
        minutes = dict.fromkeys(KINDS, 0.0)
        for config in recipe.stages:
            work, measured = stage_work(config), measure_stage(config, rollouts, make_teacher)
            stages.append(StageMeasurement(work=work, measured=measured))
            for kind, value in stage_minutes(work, measured).items():
                minutes[kind] += value
        results[recipe.name].append(RecipeBlock(minutes=minutes, total=sum(minutes.values()), stages=stages))
    return results


def block_ratios(results: Mapping[str, Sequence[RecipeBlock]], reference: str) -> dict[str, list[float]]:
    """Per recipe, its minutes per seed over the ``reference`` recipe's, block by block (repeat k with repeat
    k)."""
    base = [entry["total"] for entry in results[reference]]
    return {
        name: [entry["total"] / b for entry, b in zip(entries, base, strict=True)]
        for name, entries in results.items()
    }


def median_minutes(entries: Sequence[RecipeBlock]) -> dict[str, float]:
    """The medians over repeats of a recipe's minutes per seed, by kind of work and in total."""
    medians = {kind: median([e["minutes"][kind] for e in entries]) for kind in KINDS}
    return {**medians, "total": median([e["total"] for e in entries])}
