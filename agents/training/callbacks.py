"""The callbacks of a training run: atomic checkpoints, an evaluation whose history and best model carry
over a resume, a wall-clock budget, and progress lines for runs that share a terminal."""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback, CheckpointCallback, EvalCallback
from stable_baselines3.common.evaluation import evaluate_policy
from stable_baselines3.common.vec_env import VecEnv

from agents.common.folders import copy_atomically, naming_file, replacing_atomically, write_text_atomically
from agents.common.saved_models import checkpoint_steps, read_saved_model, save_atomically
from agents.training.curves import read_evaluations
from agents.training.outputs import RunFiles


class AtomicCheckpointCallback(CheckpointCallback):
    """SB3's CheckpointCallback, but each checkpoint is written under a temporary name and renamed, so a
    crash mid-save never leaves a truncated newest checkpoint for ``--resume`` to trip on; ``on_save`` is
    called with the step count after each save (the record's update)."""

    def __init__(
        self,
        save_freq: int,
        save_path: str,
        name_prefix: str = "rl_model",
        on_save: Callable[[int], None] | None = None,
    ) -> None:
        super().__init__(save_freq, save_path, name_prefix=name_prefix)
        self.on_save = on_save

    def _on_step(self) -> bool:
        if self.n_calls % self.save_freq == 0:
            save_atomically(self.model, Path(self._checkpoint_path(extension="zip")))
            if self.on_save is not None:
                self.on_save(self.num_timesteps)
        return True


def write_best_info(files: RunFiles, mean_return: float, timesteps: int) -> None:
    """Write the best model's mean return and step count to ``best_model.json``, atomically."""
    write_text_atomically(
        files.best_info, json.dumps({"mean_return": mean_return, "timesteps": int(timesteps)})
    )


def checkpoint_at(folder: Path, steps: int) -> Path | None:
    """The checkpoint of step ``steps`` in ``folder`` (``<name>_<steps>_steps.zip``), None when there is none."""
    return next((path for path in folder.glob("*_steps.zip") if checkpoint_steps(path) == steps), None)


def restore_best(
    files: RunFiles, kept: dict[int, float], saved: tuple[int, float | None] | None
) -> float | None:
    """Make the run's best model and ``best_model.json`` agree with the evaluations ``kept`` (step → mean
    return); returns the best mean return, None when there is none to beat.

    The best evaluation is the first of the highest mean (an evaluation replaces the best model only when
    strictly better). ``saved`` is the step count and mean return (None: unknown) of the best model on disk:
    it stays when at least as good, since it may come from an evaluation dropped at the resume; otherwise the
    best evaluation's checkpoint takes its place, as when its own save failed after it was recorded.
    """
    top = min(kept, key=lambda step: (-kept[step], step)) if kept else None
    steps, mean = saved if saved is not None else (None, None)
    if mean is None and steps in kept:
        mean = kept[steps]
    better = top is not None and (mean is None or (kept[top], -top) > (mean, -(steps or 0)))
    if top is not None and better and top != steps:
        checkpoint = checkpoint_at(files.checkpoints, top)
        if checkpoint is None:
            print(f"warning: the best evaluation, {kept[top]:.2f} at {top} steps, has no checkpoint left to be "
                  "the best model; keeping the best model saved")  # fmt: skip
        else:
            files.best_model.parent.mkdir(parents=True, exist_ok=True)
            copy_atomically(checkpoint, files.best_model)
            steps, mean = top, kept[top]
            print(f"the best evaluation, {mean:.2f} at {steps} steps, had no best model saved: taken from "
                  f"{checkpoint}")  # fmt: skip
    if steps is None or mean is None:
        return None
    write_best_info(files, mean, steps)
    return mean


def write_evaluations(
    path: Path, timesteps: list[int], results: list[list[float]], lengths: list[list[int]]
) -> None:
    """Write the evaluation history in SB3's ``evaluations.npz`` layout, atomically."""
    with replacing_atomically(path) as temporary:
        np.savez(temporary, timesteps=timesteps, results=results, ep_lengths=lengths)


class ResumableEvalCallback(EvalCallback):
    """SB3's EvalCallback over all sessions of a run, such that a failed or interrupted write loses no
    evaluation and changes no choice of the best model.

    An evaluation is due at every multiple of ``eval_freq`` × the envs' count of the run's steps (not of the
    session's, so a session resumed from any step keeps the run's schedule), on the same layouts each time
    (the eval env is seeded with ``eval_seed`` before each), so an evaluation depends only on the model. Each
    is added to ``evaluations.npz`` before anything else is written; only then is a new best saved as
    ``best/best_model.zip`` with its mean return and steps in ``best_model.json``.

    Resumed from step ``resume_step``, it loads the earlier evaluations up to that step (later ones belong to
    training that was lost with the unsaved steps, and are dropped) and makes the best model agree with them:
    the best evaluation's model is taken from its checkpoint where a failed save left an older best model, or
    none. At the start of learning it redoes the evaluation due at the resumed step when the history lacks it
    (a run stopped by a failed write of that evaluation): the resumed model is that step's checkpoint.

    Raises:
        ValueError: the earlier evaluations used another number of episodes (they could not share one array).
    """

    def __init__(
        self,
        eval_env: VecEnv,
        files: RunFiles,
        resume_step: int | None,
        eval_seed: int | None = None,
        n_eval_episodes: int = 5,
        eval_freq: int = 10000,
        deterministic: bool = True,
        verbose: int = 1,
    ) -> None:
        super().__init__(
            eval_env,
            n_eval_episodes=n_eval_episodes,
            eval_freq=eval_freq,
            log_path=None,
            best_model_save_path=None,
            deterministic=deterministic,
            verbose=verbose,
        )
        self.files = files
        self.eval_seed = eval_seed
        self.resume_step = resume_step
        self.step_interval = 0  # steps between evaluations, known once the training envs are
        self.next_due = 0
        if resume_step is not None:
            self._restore(resume_step)

    def _restore(self, resume_step: int) -> None:
        earlier: dict[int, float] = {}  # every earlier evaluation's step → mean return, dropped ones too
        history = self._earlier_evaluations()
        if history is not None:
            timesteps, results, lengths = history
            earlier = dict(zip(timesteps.tolist(), results.mean(axis=1).tolist(), strict=True))
            keep = timesteps <= resume_step
            if keep.any() and results.shape[1] != self.n_eval_episodes:
                raise ValueError(
                    f"{self.files.evaluations} holds {results.shape[1]} episodes per evaluation, the "
                    f"config asks for {self.n_eval_episodes}: keep eval_episodes to resume this run"
                )
            if not keep.all():
                print(f"dropping {int((~keep).sum())} evaluations after the resumed step {resume_step}")
            self.evaluations_timesteps = [int(t) for t in timesteps[keep]]
            self.evaluations_results = [list(map(float, r)) for r in results[keep]]
            self.evaluations_length = [list(map(int, n)) for n in lengths[keep]]
        kept = {t: earlier[t] for t in self.evaluations_timesteps}
        best = restore_best(self.files, kept, self._saved_best(earlier))
        if best is not None:
            self.best_mean_reward = best

    def _saved_best(self, earlier: dict[int, float]) -> tuple[int, float | None] | None:
        """The step count of ``best_model.zip`` and its mean return (from ``best_model.json`` when that
        describes this model, else from the evaluations, else None); None when there is no readable best
        model. An unreadable ``best_model.json`` is moved aside with a warning."""
        if not self.files.best_model.is_file():
            return None
        try:
            steps = read_saved_model(self.files.best_model).num_timesteps
        except ValueError as problem:
            print(f"warning: the best model is unreadable and will be replaced: {problem}")
            return None
        info = self._best_info()
        if self.files.best_info.is_file() and info is None:
            aside = self.files.best_info.with_name(f"{self.files.best_info.stem}.unreadable.json")
            with naming_file(aside):
                os.replace(self.files.best_info, aside)
            print(f"warning: {self.files.best_info} unreadable; kept as {aside.name}, the best model's return "
                  "is taken from the evaluations")  # fmt: skip
        if info is not None and int(info.get("timesteps", steps)) == steps:
            return steps, float(info["mean_return"])
        return steps, earlier.get(steps)

    def _best_info(self) -> dict[str, Any] | None:
        """``best_model.json``; None when there is none or it is damaged (no finite mean return)."""
        if not self.files.best_info.is_file():
            return None
        try:
            info = json.loads(self.files.best_info.read_text())
            value = float(info["mean_return"])
            int(info.get("timesteps", 0))
        except (ValueError, KeyError, TypeError, UnicodeDecodeError):
            return None
        return info if np.isfinite(value) else None

    def _earlier_evaluations(self) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """The earlier sessions' evaluations; None when there are none, or when they are unreadable: the file
        is then moved aside, so that neither the new history nor its curve or shipping mixes with it."""
        path = self.files.evaluations
        if not path.is_file():
            return None
        try:
            return read_evaluations(path)
        except ValueError as problem:
            aside = path.with_name(f"{path.stem}.unreadable{path.suffix}")
            with naming_file(aside):
                os.replace(path, aside)
            print(f"warning: earlier evaluations {path} unreadable ({problem}); kept as {aside.name}, "
                  "starting a new history")  # fmt: skip
            return None

    def _on_training_start(self) -> None:
        self.step_interval = max(1, self.eval_freq) * self.training_env.num_envs
        step = self.num_timesteps
        missing = step not in self.evaluations_timesteps
        if self.resume_step is not None and step > 0 and step % self.step_interval == 0 and missing:
            print(f"redoing the evaluation at the resumed step {step}, missing from {self.files.evaluations}")
            self._evaluate()
        self.next_due = (step // self.step_interval + 1) * self.step_interval

    def _on_step(self) -> bool:
        if self.eval_freq > 0 and self.num_timesteps >= self.next_due:
            self.next_due = (self.num_timesteps // self.step_interval + 1) * self.step_interval
            self._evaluate()
        return True

    def _evaluate(self) -> None:
        """Evaluate the model, write the history, then the best model when it is a new best.

        Raises:
            OSError: a write failed; it names the file, and the files written before it stay whole.
        """
        if self.eval_seed is not None:
            self.eval_env.seed(self.eval_seed)
        episode_returns, episode_lengths = evaluate_policy(
            self.model,
            self.eval_env,
            n_eval_episodes=self.n_eval_episodes,
            deterministic=self.deterministic,
            return_episode_rewards=True,
            warn=self.warn,
        )
        # With return_episode_rewards, one return and one length per episode.
        returns, lengths = np.atleast_1d(episode_returns), np.atleast_1d(episode_lengths)
        self.evaluations_timesteps.append(int(self.num_timesteps))
        self.evaluations_results.append([float(r) for r in returns])
        self.evaluations_length.append([int(n) for n in lengths])
        write_evaluations(
            self.files.evaluations,
            self.evaluations_timesteps,
            self.evaluations_results,
            self.evaluations_length,
        )
        mean = float(np.mean(returns))
        self.last_mean_reward = mean
        self.logger.record("eval/mean_reward", mean)
        self.logger.record("eval/mean_ep_length", float(np.mean(lengths)))
        self.logger.record("time/total_timesteps", self.num_timesteps, exclude="tensorboard")
        self.logger.dump(self.num_timesteps)
        if mean > self.best_mean_reward:
            save_atomically(self.model, self.files.best_model)
            write_best_info(self.files, mean, self.num_timesteps)
            self.best_mean_reward = mean


class WallClockBudget(BaseCallback):
    """Stops learning once the session has used ``minutes`` of wall-clock time."""

    def __init__(self, minutes: float) -> None:
        super().__init__()
        self.deadline = time.monotonic() + 60.0 * minutes

    def _on_step(self) -> bool:
        return time.monotonic() < self.deadline


class ProgressLines(BaseCallback):
    """Prints one line every ``every`` steps (steps done, of how many, and the rate this session): the progress
    report of runs that share a terminal, where progress bars would overwrite each other."""

    def __init__(self, every: int, label: str) -> None:
        super().__init__()
        self.every = max(1, every)
        self.label = label
        self._started = time.monotonic()
        self._first_step = 0
        self._next_report = 0
        self._total = 0

    def _on_training_start(self) -> None:
        self._started = time.monotonic()
        self._first_step = self.num_timesteps
        self._next_report = self.num_timesteps + self.every
        self._total = int(self.locals["total_timesteps"])  # the run's target, resumed steps included

    def _on_step(self) -> bool:
        if self.num_timesteps >= self._next_report:
            self._next_report += self.every
            rate = (self.num_timesteps - self._first_step) / max(time.monotonic() - self._started, 1e-9)
            print(
                f"{self.label}: {self.num_timesteps:,} / {self._total:,} steps ({rate:.0f} steps/s)",
                flush=True,
            )
        return True
