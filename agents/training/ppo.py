"""Trains a PPO policy on FlowNav from a YAML config (``flownav train --config configs/ppo_flow.yaml``).

:func:`train` reads top to bottom, one step after another:

1. the run: the config checked again (:class:`agents.training.train_config.TrainConfig`, every key of the
   YAML), its output folders writable;
2. the envs: ``n_envs`` training envs in subprocesses (sensor errors and courses drawn per episode where the
   config randomises them) and one held-out evaluation env;
3. the model: PPO (or RecurrentPPO) with the config's hyperparameters in view (:func:`new_model`), resumed
   from the newest readable checkpoint, or started from an earlier stage's weights;
4. the session's record (``<name>.json``), then, for a fresh run with a teacher, DAgger against it
   (:mod:`agents.training.imitation`);
5. learning, with atomic checkpoints, an evaluation on held-out seeds that carries over resumes, a wall-clock
   budget and a progress bar (:func:`make_callbacks`);
6. the policy chosen (best held-out evaluation, else the last model) and written with its config and learning
   curve (:func:`write_outputs`), the session's end in the record; then, when asked, shipped.

Everything that can end a session early (Ctrl-C, SIGTERM, a full disk, any failure) is handled by one guard,
``with run_guard(...) as guard:`` (:mod:`agents.training.run_guard`): an interrupted run still writes its
policy, a failed one says why in its record, and the env workers are closed whatever happens.

Everything goes to ``runs/<name>/`` (see :class:`agents.training.outputs.RunFiles`). Shipping to
``results/policies/`` is a separate step (``--ship``, ``--ship-only``; :mod:`agents.training.shipping`).
"""

from __future__ import annotations

import json
from dataclasses import asdict
from functools import partial
from pathlib import Path

import torch
from stable_baselines3.common.callbacks import CallbackList, ProgressBarCallback
from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm
from stable_baselines3.common.vec_env import VecEnv

from agents.common.folders import check_writable_folder, copy_atomically, replacing_atomically
from agents.common.saved_models import latest_checkpoint, load_policy_weights, save_atomically
from agents.common.seeds import checkpoint_selection_seed
from agents.training.algorithms import algorithm_class, network_kwargs, policy_alias
from agents.training.callbacks import (
    AtomicCheckpointCallback,
    ProgressLines,
    ResumableEvalCallback,
    WallClockBudget,
)
from agents.training.curves import plot_learning_curves
from agents.training.envs import build_envs
from agents.training.imitation import Teacher, TeacherFactory, imitate
from agents.training.outputs import RunFiles
from agents.training.run_guard import run_guard
from agents.training.run_record import INTERRUPTED, SessionRecord, init_summary, session_facts
from agents.training.shipping import ship_run
from agents.training.student_view import privileged_settings
from agents.training.train_config import PPOParams, TrainConfig, checked_config, init_source, rollout_note


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
            cannot be written, a fresh start in a folder holding an earlier run (see :func:`build_model`), or
            a config naming a teacher without ``make_teacher``.
        OSError: a write failed while training (full disk, file-size limit); it names the file, the
            checkpoints written before stay, and the env workers are closed.
        KeyboardInterrupt: Ctrl-C or SIGTERM during the teacher start (nothing of it is kept).
    """
    # 1. The run: its config, checked again for values set after loading, and folders that take files.
    config = checked_config(config, source=str(config_path))
    files = files or RunFiles.of(runs_dir, config.name)
    for folder in (files.run_dir, ship_to):
        if folder is not None:
            check_writable_folder(folder)
    files.run_dir.mkdir(parents=True, exist_ok=True)
    torch.set_num_threads(1)  # the env workers need the cores; small MLPs gain nothing from threads

    # 2. The envs. The teacher is built first: a privileged teacher's own settings (the planner's
    # observe_layout) go to the training envs, behind a view that hides their keys from the student
    # (agents.training.student_view).
    teacher = (
        make_teacher(config.imitation.teacher, config.imitation.teacher_params)
        if config.imitation.teacher and make_teacher
        else None
    )
    envs, eval_env = build_envs(
        config, in_process=in_process_envs, teacher_settings=privileged_settings(teacher)
    )

    with run_guard(files, envs, eval_env) as guard:
        # 3. The model: resumed, or fresh (from an earlier stage's weights where the config says).
        model, resume_step = build_model(config, envs, files, resume)

        # 4. The session's record, and from here the guard's: an early end is recorded and checkpointed.
        record = SessionRecord(
            files,
            session_facts(config, in_process_envs),
            command=command or f"flownav train --config {config_path}" + (" --resume" if resume else ""),
            keep_earlier=resume,
            steps_at_start=model.num_timesteps,
            init=init_summary(config),
        )
        guard.start(model, record, checkpoint=partial(save_checkpoint, model, config, files))
        callbacks = make_callbacks(config, eval_env, files, resume_step, record, progress_bar)
        record.restart_clock()  # the session's minutes count from here: the teacher start and learning
        if resume_step is None and config.imitation.teacher:
            guard.teacher_start(
                partial(
                    imitate,
                    model,
                    envs,
                    required_teacher(config, teacher),
                    config.imitation,
                    config.ppo.gamma,
                    config.seed,
                )
            )

        # 5. Learn up to total_timesteps (whole rollouts), then checkpoint: the resume point.
        note = rollout_note(config, model.num_timesteps)
        if note is not None:
            print(note)
        guard.learn(
            partial(
                model.learn,
                max(0, config.total_timesteps - model.num_timesteps),
                callback=callbacks,
                reset_num_timesteps=resume_step is None,
                tb_log_name=config.name,
            ),
            callbacks,
        )

        # 6. The policy, its config and learning curve; the session's end in the record.
        guard.end(selected=write_outputs(model, config, Path(config_path), files))
    print(
        f"saved {files.policy} after {model.num_timesteps} steps ({record.wall_minutes:.1f} min this session)"
    )
    if ship_to is not None:
        if guard.status == INTERRUPTED:
            print(f"interrupted: not shipping; ship it later with --ship-only --config {config_path}")
        else:
            ship_run(files, ship_to)
    return files.policy


def new_model(config: TrainConfig, envs: VecEnv, tensorboard_log: str | None = None) -> OnPolicyAlgorithm:
    """A fresh model of ``config`` on ``envs``: PPO with a ``MultiInputPolicy``, or RecurrentPPO with a
    ``MultiInputLstmPolicy`` when ``ppo.lstm_hidden_size`` > 0 (:mod:`agents.training.algorithms`), with every
    hyperparameter of the config's ``ppo`` block (:class:`agents.training.train_config.PPOParams`)."""
    ppo = config.ppo
    return algorithm_class(ppo)(
        policy_alias(ppo),
        envs,
        learning_rate=ppo.learning_rate,
        n_steps=ppo.n_steps,
        batch_size=ppo.batch_size,
        n_epochs=ppo.n_epochs,
        gamma=ppo.gamma,
        gae_lambda=ppo.gae_lambda,
        clip_range=ppo.clip_range,
        ent_coef=ppo.ent_coef,
        policy_kwargs=network_kwargs(ppo),  # net_arch, log_std_init and, when recurrent, lstm_hidden_size
        tensorboard_log=tensorboard_log,
        seed=config.seed,
        device="cpu",
        verbose=0,
    )


def hyperparameters(params: PPOParams) -> str:
    """The ``ppo`` block as one line (``learning_rate=0.0003, n_steps=1024, ...``), printed as a run starts."""
    return ", ".join(f"{name}={value}" for name, value in asdict(params).items())


def build_model(
    config: TrainConfig, envs: VecEnv, files: RunFiles, resume: bool
) -> tuple[OnPolicyAlgorithm, int | None]:
    """PPO resumed from the newest readable checkpoint, or a fresh one; the resumed step count or None.

    Raises:
        ValueError: a fresh start in a folder that holds an earlier run's evaluations, best model or
            checkpoints, which would otherwise mix with this run's.
    """
    checkpoint = latest_checkpoint(files.checkpoints) if resume else None
    if checkpoint is not None:
        # The checkpoint carries its own hyperparameters (SB3's load), those it was started with.
        model: OnPolicyAlgorithm = algorithm_class(config.ppo).load(
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
    print(f"{config.name}: {algorithm_class(config.ppo).__name__} with {hyperparameters(config.ppo)}")
    model = new_model(config, envs, tensorboard_log=str(files.tensorboard))
    source = init_source(config)
    if source is not None:
        saved = load_policy_weights(model, source)
        print(f"starting from the weights of {source} ({saved.num_timesteps} steps)")
    return model, None


def required_teacher(config: TrainConfig, teacher: Teacher | None) -> Teacher:
    """The teacher the config names, as ``make_teacher`` built it.

    Raises:
        ValueError: no ``make_teacher`` was given to build the teacher the config names.
    """
    if teacher is None:
        raise ValueError(
            f"config {config.name!r} names the teacher {config.imitation.teacher!r}, but no make_teacher was "
            "given to build it (flownav train passes agents.policies.teachers.make_teacher)"
        )
    return teacher


def make_callbacks(
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
    # Our own bar rather than learn(progress_bar=True): a session that stops early must close it (the run
    # guard does), or its refresh thread goes on printing into whatever runs next.
    if progress_bar:
        callbacks.append(ProgressBarCallback())
    else:
        callbacks.append(ProgressLines(config.checkpoint_every, f"{config.name} seed {config.seed}"))
    return CallbackList(callbacks)


def save_checkpoint(model: OnPolicyAlgorithm, config: TrainConfig, files: RunFiles) -> None:
    """The model as ``checkpoints/<name>_<steps>_steps.zip``, the point a resumed run continues from."""
    save_atomically(model, files.checkpoints / f"{config.name}_{model.num_timesteps}_steps.zip")


def write_outputs(model: OnPolicyAlgorithm, config: TrainConfig, config_path: Path, files: RunFiles) -> str:
    """Write the run's policy (:func:`select_policy`), a copy of its config beside it and its learning curve;
    returns how the policy was selected, for the record."""
    selected = select_policy(model, files)
    if config_path.resolve() != files.config.resolve():
        copy_atomically(config_path, files.config)
    if files.evaluations.exists():
        with replacing_atomically(files.curve) as temporary:
            plot_learning_curves({"mean return (held-out seeds)": files.evaluations}, temporary, config.name)
    return selected


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
