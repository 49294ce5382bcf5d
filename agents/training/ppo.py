"""Trains a PPO policy on FlowNav from a YAML config (``flownav train --config configs/ppo_flow.yaml``).

Read top to bottom: check the config and that the output folders take files; build ``n_envs`` environments in
subprocesses (with sensor errors randomised per episode for a robust policy); build PPO, or resume it from the
newest readable checkpoint; record the session's start; learn with a progress bar, TensorBoard logs, atomic
checkpoints, an evaluation on held-out seeds that carries over resumes, and a wall-clock budget; then, Ctrl-C
or not, select the policy and write it with its config, learning curve and the session's end in the record.
A failed write (full disk) ends the run with that one error, after closing the env workers.

Everything goes to ``runs/<name>/`` (see :class:`agents.training.outputs.RunFiles`). Shipping to
``results/policies/`` is a separate step (``--ship``, ``--ship-only``; :mod:`agents.training.shipping`).
"""

from __future__ import annotations

import json
from contextlib import suppress
from pathlib import Path
from typing import Any

import torch
from stable_baselines3.common.callbacks import CallbackList, ProgressBarCallback
from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm
from stable_baselines3.common.vec_env import VecEnv

from agents.common.folders import (
    check_writable_folder,
    copy_atomically,
    named_os_error,
    replacing_atomically,
)
from agents.common.interrupts import stop_signals_interrupt
from agents.common.machine import available_cores, code_version, cpu_model
from agents.common.saved_models import latest_checkpoint, load_policy_weights, save_atomically
from agents.common.seeds import checkpoint_selection_seed
from agents.training.algorithms import algorithm_class, algorithm_kwargs, network_kwargs, policy_alias
from agents.training.callbacks import (
    AtomicCheckpointCallback,
    ProgressLines,
    ResumableEvalCallback,
    WallClockBudget,
)
from agents.training.curves import plot_learning_curves
from agents.training.envs import build_envs, close_quietly
from agents.training.imitation import Teacher, TeacherFactory, imitate
from agents.training.outputs import RunFiles
from agents.training.run_record import FAILED, FINISHED, INTERRUPTED, SessionRecord
from agents.training.shipping import ship_run
from agents.training.student_view import privileged_settings
from agents.training.train_config import TrainConfig, checked_config, init_source, rollout_note
from flownav_env.rendering import gl_renderer_name
from flownav_env.settings import ENV_ESTIMATOR_DEFAULTS


def plot_learning_curve(evaluations: Path, output: Path, title: str) -> None:
    """The run's learning curve: mean held-out return (and its min–max band) against steps."""
    with replacing_atomically(output) as temporary:
        plot_learning_curves({"mean return (held-out seeds)": evaluations}, temporary, title)


def select_policy(model: OnPolicyAlgorithm, files: RunFiles) -> str:
    """Write the run's policy: the model with the best mean return on the held-out training-eval seeds over
    all sessions (kept as ``best/best_model.zip``), else the last one; returns which, for the record.

    PPO's return on a fresh batch of layouts swings a lot between updates, so the last update is often not
    the best policy seen. The selection uses the eval callback's seeds (from 500,000), never the
    benchmark's evaluation seeds (from 1,000,000).
    """
    if files.best_model.is_file() and files.best_info.is_file():
        best = json.loads(files.best_info.read_text())
        copy_atomically(files.best_model, files.policy)
        return f"best held-out eval: mean return {best['mean_return']:.2f} at {best['timesteps']} steps"
    save_atomically(model, files.policy)
    return f"last: {model.num_timesteps} steps"


def new_model(config: TrainConfig, envs: VecEnv, tensorboard_log: str | None = None) -> OnPolicyAlgorithm:
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


def _build_model(
    config: TrainConfig, envs: VecEnv, files: RunFiles, resume: bool
) -> tuple[OnPolicyAlgorithm, int | None]:
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


def session_facts(config: TrainConfig, in_process_envs: bool) -> dict[str, Any]:
    """What a session runs with, for its entry in the record: the budget, the machine and the code."""
    return {
        "total_timesteps_asked": config.total_timesteps,
        "max_minutes": config.max_minutes,
        "cpu": cpu_model(),
        "cores": available_cores(),
        "n_envs": config.n_envs,
        "env_workers": "in process" if in_process_envs or config.n_envs == 1 else "one subprocess per env",
        # What the policy saw depends on these as much as on the config: record them per session.
        "code": code_version(),
        "env_estimator_defaults": dict(ENV_ESTIMATOR_DEFAULTS),
        "gl_renderer": gl_renderer_name(),
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
    command: str | None = None,
    make_teacher: TeacherFactory | None = None,
) -> Path:
    """Run the training described by ``config`` into ``runs_dir/<name>/`` (or ``files``, for one of several
    training seeds); returns the run's policy path.

    ``in_process_envs`` steps the envs in this process instead of one worker each (the same rollouts, see
    :func:`agents.training.envs.build_envs`), for seeds trained side by side; ``progress_bar=False`` prints a
    line every ``checkpoint_every`` steps instead, where several runs share one terminal. ``command`` is the
    command line recorded for the session (default: ``flownav train --config <config_path>``).
    ``make_teacher`` builds the agent a config's ``imitation.teacher`` names (``agents.policies.teachers.make_teacher``;
    the rules live above this layer); a fresh run with a teacher imitates it before PPO
    (:mod:`agents.training.imitation`).

    Ships the run to ``ship_to`` when given and the session was not interrupted (an interrupted run is
    shipped deliberately later, with :func:`agents.training.shipping.ship_run`); whether it was, the record
    says (:func:`agents.training.run_record.interrupted_at`).

    Raises:
        ValueError: a config value outside its range (``total_timesteps`` 0, say), an output folder that
            cannot be written, or a fresh start in a folder holding an earlier run (see :func:`_build_model`).
        OSError: a write failed while training (full disk, file-size limit); it names the file, the
            checkpoints written before stay, and the env workers are closed.
    """
    config = checked_config(config, source=str(config_path))
    files = files or RunFiles.of(runs_dir, config.name)
    for folder in (files.run_dir, ship_to):
        if folder is not None:
            check_writable_folder(folder)
    files.run_dir.mkdir(parents=True, exist_ok=True)
    torch.set_num_threads(1)  # the env workers need the cores; small MLPs gain nothing from threads
    # Built before the envs: a privileged teacher's own settings (the planner's observe_layout) go to the
    # training envs, behind a view that hides their keys from the student (agents.training.student_view).
    teacher = (
        make_teacher(config.imitation.teacher, config.imitation.teacher_params)
        if config.imitation.teacher and make_teacher
        else None
    )
    envs, eval_env = build_envs(
        config, in_process=in_process_envs, teacher_settings=privileged_settings(teacher)
    )
    # Workers ignore stop signals, so one left open would keep the process from exiting: close them whatever
    # happens.
    try:
        model, resume_step = _build_model(config, envs, files, resume)
        record = SessionRecord(
            files,
            session_facts(config, in_process_envs),
            command=command or f"flownav train --config {config_path}" + (" --resume" if resume else ""),
            keep_earlier=resume,
            steps_at_start=model.num_timesteps,
            init=init_summary(config),
        )
        callbacks = _callbacks(config, eval_env, files, resume_step, record, progress_bar)
        record.restart_clock()  # the session's minutes count from here: the teacher start and learning
        if resume_step is None and config.imitation.teacher:
            _teacher_start(model, envs, config, record, teacher)
        status = _learn(model, config, files, record, callbacks, resume_step)
    finally:
        close_quietly(envs)
        close_quietly(eval_env)

    try:
        selected = select_policy(model, files)
        if Path(config_path).resolve() != files.config.resolve():
            copy_atomically(config_path, files.config)
        if files.evaluations.exists():
            plot_learning_curve(files.evaluations, files.curve, config.name)
        record.end(status, model.num_timesteps, selected=selected)
    except Exception as error:
        with suppress(Exception):  # the record says why, where the disk still takes it
            record.end(FAILED, model.num_timesteps, error=f"{type(error).__name__}: {error}")
        raise
    print(
        f"saved {files.policy} after {model.num_timesteps} steps ({record.wall_minutes:.1f} min this session)"
    )
    if ship_to is not None:
        if status == INTERRUPTED:
            print(f"interrupted: not shipping; ship it later with --ship-only --config {config_path}")
        else:
            ship_run(files, ship_to)
    return files.policy


def _teacher_start(
    model: OnPolicyAlgorithm,
    envs: VecEnv,
    config: TrainConfig,
    record: SessionRecord,
    teacher: Teacher | None,
) -> None:
    """DAgger against ``teacher`` (the config's, built by ``make_teacher``) on the training envs, before PPO;
    its summary goes into the session's record (env steps, minutes, losses per round).

    Raises:
        ValueError: no ``make_teacher`` was given to build the teacher the config names.
    """
    if teacher is None:
        raise ValueError(
            f"config {config.name!r} names the teacher {config.imitation.teacher!r}, but no make_teacher was "
            "given to build it (flownav train passes agents.policies.teachers.make_teacher)"
        )
    try:
        with stop_signals_interrupt():
            summary = imitate(
                model,
                envs,
                teacher,
                config.imitation,
                config.ppo.gamma,
                config.seed,
            )
    except KeyboardInterrupt:
        # Nothing of a teacher start is checkpointed (it is minutes): resuming starts the run afresh.
        print("interrupted during the teacher start: the same command starts the run again")
        record.end(INTERRUPTED, 0)
        raise
    record.session["imitation"] = summary
    record.write()


def _callbacks(
    config: TrainConfig,
    eval_env: VecEnv,
    files: RunFiles,
    resume_step: int | None,
    record: SessionRecord,
    progress_bar: bool,
) -> CallbackList:
    """Checkpoints (each updating the record), the held-out evaluation, the wall-clock budget and, without a
    progress bar, progress lines."""
    per_env = max(1, config.n_envs)
    callbacks = [
        AtomicCheckpointCallback(
            max(1, config.checkpoint_every // per_env),
            str(files.checkpoints),
            name_prefix=config.name,
            on_save=record.progress,
        ),
        ResumableEvalCallback(
            eval_env,
            files,
            resume_step,
            eval_seed=checkpoint_selection_seed(config.seed),
            n_eval_episodes=config.eval_episodes,
            eval_freq=max(1, config.eval_every // per_env),
            deterministic=True,
            verbose=0,
        ),
        WallClockBudget(config.max_minutes),
    ]
    # Our own bar rather than learn(progress_bar=True): a session that stops early must close it (_learn), or its
    # refresh thread goes on printing into whatever runs next.
    if progress_bar:
        callbacks.append(ProgressBarCallback())
    else:
        callbacks.append(ProgressLines(config.checkpoint_every, f"{config.name} seed {config.seed}"))
    return CallbackList(callbacks)


def _learn(
    model: OnPolicyAlgorithm,
    config: TrainConfig,
    files: RunFiles,
    record: SessionRecord,
    callbacks: CallbackList,
    resume_step: int | None,
) -> str:
    """Learn up to ``total_timesteps`` and save the final checkpoint, the resume point; returns the session's
    status, :data:`FINISHED` or :data:`INTERRUPTED` (Ctrl-C or SIGTERM).

    Raises:
        OSError: a write failed (full disk, file-size limit), naming the file (the run's folder when the
            writer did not say); the session is recorded as failed where the disk still allows.
    """
    note = rollout_note(config, model.num_timesteps)
    if note is not None:
        print(note)
    try:
        with stop_signals_interrupt():
            model.learn(
                max(0, config.total_timesteps - model.num_timesteps),
                callback=callbacks,
                reset_num_timesteps=resume_step is None,
                tb_log_name=config.name,
            )
    except KeyboardInterrupt:
        # Ctrl-C or SIGTERM ends this session early; what was learned is still saved.
        print(f"interrupted at {model.num_timesteps} steps: saving; --resume continues from here")
        _save_checkpoint(model, config, files)
        return INTERRUPTED
    except BaseException as error:
        # Keep what can still be kept; a second failure (the same full disk) must not hide the first. The
        # record goes first: it is the smallest write, and a checkpoint's failed save may leave no room for it.
        with suppress(Exception):
            record.end(FAILED, model.num_timesteps, error=f"{type(error).__name__}: {error}")
        with suppress(Exception):
            _save_checkpoint(model, config, files)
        if isinstance(error, OSError) and not isinstance(error, ConnectionError):
            raise named_os_error(error, files.run_dir) from None
        raise
    finally:
        for bar in callbacks.callbacks:
            if isinstance(bar, ProgressBarCallback) and hasattr(bar, "pbar"):
                bar.pbar.close()  # idempotent: a finished session closed it already
    _save_checkpoint(model, config, files)
    return FINISHED


def _save_checkpoint(model: OnPolicyAlgorithm, config: TrainConfig, files: RunFiles) -> None:
    save_atomically(model, files.checkpoints / f"{config.name}_{model.num_timesteps}_steps.zip")
