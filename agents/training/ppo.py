"""Trains a PPO policy on FlowNav from a YAML config (``flownav train --config configs/ppo_flow.yaml``).

Read top to bottom: check the config; build ``n_envs`` environments in subprocesses (with sensor errors
randomised per episode for a robust policy); build PPO, or resume it from the newest readable checkpoint; learn
with a progress bar, TensorBoard logs, atomic checkpoints, an evaluation on held-out seeds that carries over
resumes, and a wall-clock budget; then, Ctrl-C or not, select the policy and write it with its config, record
and learning curve.

Everything goes to ``runs/<name>/`` (see :class:`agents.training.outputs.RunFiles`). Shipping to
``results/policies/`` is a separate step (``--ship``, ``--ship-only``; :mod:`agents.training.shipping`).
"""

from __future__ import annotations

import json
import os
import shutil
import time
from pathlib import Path
from typing import Any

from agents.common.machine import available_cores, code_version, cpu_model, gl_renderer
from agents.training.algorithms import algorithm_class, algorithm_kwargs, network_kwargs, policy_alias
from agents.training.config import TrainConfig, checked_config, init_source
from agents.training.curves import plot_learning_curves
from agents.training.envs import build_envs, close_quietly
from agents.training.interrupts import stop_signals_interrupt
from agents.training.outputs import RunFiles
from agents.training.saved_models import latest_checkpoint, load_policy_weights, save_atomically
from agents.training.shipping import ship_run
from flownav_env.settings import ENV_ESTIMATOR_DEFAULTS


def plot_learning_curve(evaluations: Path, output: Path, title: str) -> None:
    """The run's learning curve: mean held-out return (and its min–max band) against steps."""
    temporary = output.with_name(f"{output.stem}.tmp.png")
    plot_learning_curves({"mean return (held-out seeds)": evaluations}, temporary, title)
    os.replace(temporary, output)


def select_policy(model: Any, files: RunFiles) -> str:
    """Write the run's policy: the model with the best mean return on the held-out training-eval seeds over
    all sessions (kept as ``best/best_model.zip``), else the last one; returns which, for the record.

    PPO's return on a fresh batch of layouts swings a lot between updates, so the last update is often not
    the best policy seen. The selection uses the eval callback's seeds (from 500,000), never the
    benchmark's evaluation seeds (from 1,000,000).
    """
    if files.best_model.is_file() and files.best_info.is_file():
        best = json.loads(files.best_info.read_text())
        temporary = files.policy.with_name(f"{files.policy.stem}.tmp.zip")
        shutil.copyfile(files.best_model, temporary)
        os.replace(temporary, files.policy)
        return f"best held-out eval: mean return {best['mean_return']:.2f} at {best['timesteps']} steps"
    save_atomically(model, files.policy)
    return f"last: {model.num_timesteps} steps"


def new_model(config: TrainConfig, envs: Any, tensorboard_log: str | None = None) -> Any:
    """A fresh model of ``config`` on ``envs``: PPO with a ``MultiInputPolicy``, or RecurrentPPO with a
    ``MultiInputLstmPolicy`` when ``ppo.lstm_hidden_size`` > 0 (:mod:`agents.training.algorithms`)."""
    return algorithm_class(config.ppo)(
        policy_alias(config.ppo),
        envs,
        policy_kwargs=network_kwargs(config.ppo),
        tensorboard_log=tensorboard_log,
        seed=config.seed,
        device="cpu",
        verbose=0,
        **algorithm_kwargs(config.ppo),
    )


def _build_model(config: TrainConfig, envs: Any, files: RunFiles, resume: bool) -> tuple[Any, int | None]:
    """PPO resumed from the newest readable checkpoint, or a fresh one; the resumed step count or None.

    Raises:
        ValueError: a fresh start in a folder that holds an earlier run's evaluations, best model or
            checkpoints, which would otherwise mix with this run's.
    """
    checkpoint = latest_checkpoint(files.checkpoints) if resume else None
    if checkpoint is not None:
        model = algorithm_class(config.ppo).load(
            checkpoint, env=envs, device="cpu", tensorboard_log=str(files.tensorboard)
        )
        print(f"resuming from {checkpoint} at {model.num_timesteps} steps")
        return model, model.num_timesteps
    leftovers = [p for p in (files.evaluations, files.best_model) if p.exists()]
    leftovers += sorted(files.checkpoints.glob("*.zip")) if files.checkpoints.is_dir() else []
    if leftovers:
        why = "has no readable checkpoint" if resume else "already holds a run"
        raise ValueError(
            f"{files.run_dir} {why} ({leftovers[0].name}, ...): continue it with --resume, or move the "
            "folder away (or pick another --runs-dir) to start afresh"
        )
    if resume:
        print(f"no checkpoint in {files.checkpoints}: starting fresh")
    model = new_model(config, envs, tensorboard_log=str(files.tensorboard))
    source = init_source(config)
    if source is not None:
        saved = load_policy_weights(model, source)
        print(f"starting from the weights of {source} ({saved.num_timesteps} steps)")
    return model, None


def init_summary(config: TrainConfig) -> dict[str, Any] | None:
    """For the record: the earlier stage a run started from (``init_from``), its steps and training minutes
    (from the record beside it, when there is one), so a curriculum's cost per seed adds up."""
    source = init_source(config)
    if source is None:
        return None
    record = source.with_suffix(".json")
    earlier = json.loads(record.read_text()) if record.is_file() else {}
    return {
        "path": str(source),
        "timesteps": earlier.get("total_timesteps"),
        "wall_minutes": earlier.get("total_wall_minutes"),
    }


def train(
    config: TrainConfig,
    *,
    config_path: Path,
    resume: bool,
    runs_dir: Path,
    ship_to: Path | None = None,
    files: RunFiles | None = None,
    in_process_envs: bool = False,
    progress_bar: bool = True,
) -> Path:
    """Run the training described by ``config`` into ``runs_dir/<name>/`` (or ``files``, for one of several
    training seeds); returns the run's policy path.

    ``in_process_envs`` steps the envs in this process instead of one worker each (the same rollouts, see
    :func:`agents.training.envs.build_envs`), for seeds trained side by side; ``progress_bar=False`` prints a
    line every ``checkpoint_every`` steps instead, where several runs share one terminal.

    Ships the run to ``ship_to`` when given and the session was not interrupted (an interrupted run is
    shipped deliberately later, with :func:`agents.training.shipping.ship_run`).

    Raises:
        ValueError: a config value outside its range (``total_timesteps`` 0, say), or a fresh start in a
            folder holding an earlier run (see :func:`_build_model`).
    """
    import torch
    from stable_baselines3.common.callbacks import CallbackList

    from agents.training.callbacks import (
        AtomicCheckpointCallback,
        ProgressLines,
        ResumableEvalCallback,
        WallClockBudget,
    )

    config = checked_config(config, source=str(config_path))
    torch.set_num_threads(1)  # the env workers need the cores; small MLPs gain nothing from threads
    files = files or RunFiles.of(runs_dir, config.name)
    envs, eval_env = build_envs(config, in_process=in_process_envs)
    try:
        model, resume_step = _build_model(config, envs, files, resume)
        per_env = max(1, config.n_envs)
        callbacks = CallbackList(
            [
                AtomicCheckpointCallback(
                    max(1, config.checkpoint_every // per_env),
                    str(files.checkpoints),
                    name_prefix=config.name,
                ),
                ResumableEvalCallback(
                    eval_env,
                    files,
                    resume_step,
                    n_eval_episodes=config.eval_episodes,
                    eval_freq=max(1, config.eval_every // per_env),
                    deterministic=True,
                    verbose=0,
                ),
                WallClockBudget(config.max_minutes),
            ]
        )
        if not progress_bar:
            callbacks.callbacks.append(
                ProgressLines(config.checkpoint_every, f"{config.name} seed {config.seed}")
            )
    except BaseException:
        close_quietly(envs)
        close_quietly(eval_env)
        raise
    started = time.perf_counter()
    steps_before = model.num_timesteps
    interrupted = False
    try:
        with stop_signals_interrupt():
            model.learn(
                max(0, config.total_timesteps - model.num_timesteps),
                callback=callbacks,
                progress_bar=progress_bar,
                reset_num_timesteps=resume_step is None,
                tb_log_name=config.name,
            )
    except KeyboardInterrupt:
        # Ctrl-C or SIGTERM ends this session early; what was learned is still saved below.
        interrupted = True
        print(f"interrupted at {model.num_timesteps} steps: saving; --resume continues from here")
    finally:
        # Interrupted or not, keep what was learned: the checkpoint is the resume point.
        save_atomically(model, files.checkpoints / f"{config.name}_{model.num_timesteps}_steps.zip")
        close_quietly(envs)
        close_quietly(eval_env)
    wall_minutes = (time.perf_counter() - started) / 60.0

    selected = select_policy(model, files)
    if Path(config_path).resolve() != files.config.resolve():
        shutil.copyfile(config_path, files.config)
    if files.evaluations.exists():
        plot_learning_curve(files.evaluations, files.curve, config.name)
    session = {
        "steps_this_session": int(model.num_timesteps - steps_before),
        "wall_minutes": round(wall_minutes, 1),
        "steps_per_second": round((model.num_timesteps - steps_before) / max(wall_minutes * 60, 1e-9), 1),
        "interrupted": interrupted,
        "total_timesteps_asked": config.total_timesteps,
        "max_minutes": config.max_minutes,
        "cpu": cpu_model(),
        "cores": available_cores(),
        "n_envs": config.n_envs,
        "env_workers": "in process" if in_process_envs or config.n_envs == 1 else "one subprocess per env",
        # What the policy saw depends on these as much as on the config: record them per session.
        "code": code_version(),
        "env_estimator_defaults": dict(ENV_ESTIMATOR_DEFAULTS),
        "gl_renderer": gl_renderer(),
    }
    write_record(
        files,
        session,
        selected,
        model.num_timesteps,
        config_path,
        resumed=resume_step is not None,
        init=init_summary(config),
    )
    print(f"saved {files.policy} after {model.num_timesteps} steps ({wall_minutes:.1f} min this session)")
    if ship_to is not None:
        if interrupted:
            print(f"interrupted: not shipping; ship it later with --ship-only --config {config_path}")
        else:
            ship_run(files, ship_to)
    return files.policy


def write_record(
    files: RunFiles,
    session: dict,
    selected: str,
    total_timesteps: int,
    config_path: Path,
    *,
    resumed: bool,
    init: dict[str, Any] | None = None,
) -> None:
    """Append ``session`` to the run's record (a resumed run keeps its earlier sessions) and update the
    totals over all sessions, with the earlier stage's ``init`` (:func:`init_summary`) added to the cost;
    written atomically."""
    record = json.loads(files.record.read_text()) if resumed and files.record.is_file() else {"sessions": []}
    record["sessions"].append(session)
    record["total_timesteps"] = int(total_timesteps)
    record["selected"] = selected
    record["total_wall_minutes"] = round(sum(s["wall_minutes"] for s in record["sessions"]), 1)
    if init is not None:
        record["init_from"] = init
        record["total_wall_minutes_with_init"] = round(
            record["total_wall_minutes"] + (init["wall_minutes"] or 0), 1
        )
    record["command"] = f"flownav train --config {config_path}" + (" --resume" if resumed else "")
    temporary = files.record.with_suffix(".tmp")
    temporary.write_text(json.dumps(record, indent=2))
    os.replace(temporary, files.record)
