"""Trains a PPO policy on FlowNav from a YAML config (``flownav train --config configs/ppo_flow.yaml``).

Read top to bottom: load and validate the config; build ``n_envs`` environments in subprocesses (with sensor
errors randomised per episode for a robust policy); build PPO, or resume it from the newest checkpoint; learn
with a progress bar, TensorBoard logs, periodic checkpoints, an evaluation on held-out seeds and a wall-clock
budget; save the policy with its config, learning curve and the hardware and time it took.

Outputs: ``runs/<name>/`` (TensorBoard logs, checkpoints, evaluations) and ``results/policies/<name>.zip``
(+ ``.yaml`` config copy, ``_learning_curve.png``, ``.json`` training record).
"""

from __future__ import annotations

import json
import shutil
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np

from agents.common.machine import available_cores, code_version, cpu_model, gl_renderer
from agents.common.seeds import VALIDATION_SEED_START
from agents.training.config import TrainConfig
from agents.training.curves import plot_learning_curves
from flownav_env.settings import ENV_ESTIMATOR_DEFAULTS


def make_env_factory(config: TrainConfig, rank: int):
    """A picklable-by-closure factory for SubprocVecEnv workers."""

    def factory():
        import gymnasium as gym
        from stable_baselines3.common.monitor import Monitor

        import flownav_env  # noqa: F401  (registers the ids in the worker)
        from agents.training.wrappers import SensorRandomization

        env = gym.make(config.env_id, **config.env)
        if any(asdict(config.randomize).values()):
            env = SensorRandomization(env, asdict(config.randomize))
        return Monitor(env)

    return factory


def latest_checkpoint(directory: Path) -> Path | None:
    checkpoints = sorted(directory.glob("*_steps.zip"), key=lambda p: int(p.stem.split("_")[-2]))
    return checkpoints[-1] if checkpoints else None


def plot_learning_curve(evaluations: Path, output: Path, title: str) -> None:
    plot_learning_curves({"mean return (held-out seeds)": evaluations}, output, title)


def select_policy(model, run_dir: Path, policy_path: Path) -> str:
    """Ship the checkpoint with the best mean return on the held-out training-eval seeds (SB3's EvalCallback
    keeps it as ``best/best_model.zip``), else the last one; returns which, for the training record.

    PPO's return on a fresh batch of layouts swings a lot between updates, so the last update is often not
    the best policy seen. The selection uses the eval callback's seeds (from 500,000), never the
    benchmark's evaluation seeds (from 1,000,000).
    """
    best = run_dir / "best" / "best_model.zip"
    evaluations = run_dir / "evaluations.npz"
    if best.exists() and evaluations.exists():
        data = np.load(evaluations)
        means = data["results"].mean(axis=1)
        index = int(np.argmax(means))
        shutil.copyfile(best, policy_path)
        return f"best held-out eval: mean return {means[index]:.2f} at {int(data['timesteps'][index])} steps"
    model.save(policy_path)
    return f"last: {model.num_timesteps} steps"


def train(
    config: TrainConfig, *, config_path: Path, resume: bool, runs_dir: Path, policies_dir: Path
) -> Path:
    """Run the training described by ``config``; returns the saved policy's path."""
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import (
        BaseCallback,
        CallbackList,
        CheckpointCallback,
        EvalCallback,
    )
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    torch.set_num_threads(1)  # the env workers need the cores; small MLPs gain nothing from threads
    run_dir = runs_dir / config.name
    checkpoint_dir = run_dir / "checkpoints"
    factories = [make_env_factory(config, i) for i in range(config.n_envs)]
    vec_cls = SubprocVecEnv if config.n_envs > 1 else DummyVecEnv
    envs = vec_cls(factories, **({"start_method": "forkserver"} if vec_cls is SubprocVecEnv else {}))
    envs.seed(config.seed)
    eval_env = DummyVecEnv([make_env_factory(config, 0)])
    eval_env.seed(VALIDATION_SEED_START + config.seed)

    checkpoint = latest_checkpoint(checkpoint_dir) if resume else None
    if checkpoint is not None:
        model = PPO.load(checkpoint, env=envs, device="cpu", tensorboard_log=str(run_dir / "tb"))
        print(f"resuming from {checkpoint} at {model.num_timesteps} steps")
    else:
        if resume:
            print(f"no checkpoint in {checkpoint_dir}: starting fresh")
        params = asdict(config.ppo)
        net_arch = params.pop("net_arch")
        log_std_init = params.pop("log_std_init")
        model = PPO(
            "MultiInputPolicy",
            envs,
            policy_kwargs={"net_arch": net_arch, "log_std_init": log_std_init},
            tensorboard_log=str(run_dir / "tb"),
            seed=config.seed,
            device="cpu",
            verbose=0,
            **params,
        )

    class WallClockBudget(BaseCallback):
        """Stops learning once the run has used ``max_minutes`` (this session's share)."""

        def __init__(self, minutes: float) -> None:
            super().__init__()
            self.deadline = time.monotonic() + 60.0 * minutes

        def _on_step(self) -> bool:
            return time.monotonic() < self.deadline

    per_env = max(1, config.n_envs)
    callbacks = CallbackList(
        [
            CheckpointCallback(
                max(1, config.checkpoint_every // per_env), str(checkpoint_dir), name_prefix=config.name
            ),
            EvalCallback(
                eval_env,
                n_eval_episodes=config.eval_episodes,
                eval_freq=max(1, config.eval_every // per_env),
                log_path=str(run_dir),
                best_model_save_path=str(run_dir / "best"),
                deterministic=True,
                verbose=0,
            ),
            WallClockBudget(config.max_minutes),
        ]
    )
    started = time.perf_counter()
    steps_before = model.num_timesteps
    remaining = max(0, config.total_timesteps - model.num_timesteps)
    try:
        model.learn(
            remaining,
            callback=callbacks,
            progress_bar=True,
            reset_num_timesteps=checkpoint is None,
            tb_log_name=config.name,
        )
    except KeyboardInterrupt:
        # Ctrl-C ends this session's share early; what was learned is still saved and shipped below.
        print(f"interrupted at {model.num_timesteps} steps: saving; --resume continues from here")
    finally:
        # Interrupted or not, keep what was learned: the checkpoint is the resume point.
        model.save(checkpoint_dir / f"{config.name}_{model.num_timesteps}_steps.zip")
        envs.close()
        eval_env.close()
    wall_minutes = (time.perf_counter() - started) / 60.0

    policies_dir.mkdir(parents=True, exist_ok=True)
    policy_path = policies_dir / f"{config.name}.zip"
    selected = select_policy(model, run_dir, policy_path)
    shutil.copyfile(config_path, policies_dir / f"{config.name}.yaml")
    evaluations = run_dir / "evaluations.npz"
    if evaluations.exists():
        plot_learning_curve(evaluations, policies_dir / f"{config.name}_learning_curve.png", config.name)
        shutil.copyfile(evaluations, policies_dir / f"{config.name}_evaluations.npz")
    record_path = policies_dir / f"{config.name}.json"
    record = (
        json.loads(record_path.read_text())
        if record_path.exists() and checkpoint is not None
        else {"sessions": []}
    )
    record["sessions"].append(
        {
            "steps_this_session": int(model.num_timesteps - steps_before),
            "wall_minutes": round(wall_minutes, 1),
            "steps_per_second": round((model.num_timesteps - steps_before) / max(wall_minutes * 60, 1e-9), 1),
            "cpu": cpu_model(),
            "cores": available_cores(),
            "n_envs": config.n_envs,
            # What the policy saw depends on these as much as on the config: record them per session.
            "code": code_version(),
            "env_estimator_defaults": dict(ENV_ESTIMATOR_DEFAULTS),
            "gl_renderer": gl_renderer(),
        }
    )
    record["total_timesteps"] = int(model.num_timesteps)
    record["selected"] = selected
    record["total_wall_minutes"] = round(sum(s["wall_minutes"] for s in record["sessions"]), 1)
    record["command"] = f"flownav train --config {config_path}" + (" --resume" if resume else "")
    record_path.write_text(json.dumps(record, indent=2))
    print(f"saved {policy_path} after {model.num_timesteps} steps ({wall_minutes:.1f} min this session)")
    return policy_path
