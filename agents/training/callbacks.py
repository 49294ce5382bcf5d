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

from agents.common.folders import naming_file, write_text_atomically
from agents.common.saved_models import read_saved_model, save_atomically
from agents.training.outputs import RunFiles


class AtomicCheckpointCallback(CheckpointCallback):
    """SB3's CheckpointCallback, but each checkpoint is written under a temporary name and renamed, so a
    crash mid-save never leaves a truncated newest checkpoint for ``--resume`` to trip on; ``on_save`` is
    called with the step count after each save (the record's update)."""

    def __init__(self, *args: Any, on_save: Callable[[int], None] | None = None, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.on_save = on_save

    def _on_step(self) -> bool:
        if self.n_calls % self.save_freq == 0:
            save_atomically(self.model, Path(self._checkpoint_path(extension="zip")))
            if self.on_save is not None:
                self.on_save(self.num_timesteps)
        return True


class SaveBestModel(BaseCallback):
    """Run by the evaluation on a new best: saves the model atomically with its mean return and step count
    beside it, so a resumed run knows the best to beat and the record can name it."""

    def __init__(self, files: RunFiles) -> None:
        super().__init__()
        self.files = files

    def _on_step(self) -> bool:
        save_atomically(self.model, self.files.best_model)
        info = {"mean_return": float(self.parent.best_mean_reward), "timesteps": int(self.num_timesteps)}
        write_text_atomically(self.files.best_info, json.dumps(info))
        return True


def _evaluations_problem(timesteps: np.ndarray, results: np.ndarray, lengths: np.ndarray) -> str | None:
    """What is wrong with the arrays of an ``evaluations.npz``, or None when they fit together."""
    if not all(np.issubdtype(array.dtype, np.number) for array in (timesteps, results, lengths)):
        return "its arrays are not numbers"
    if timesteps.ndim != 1 or results.ndim != 2 or results.shape[1] == 0:
        return f"timesteps of shape {timesteps.shape} and results of shape {results.shape} are not one row per step"
    if results.shape[0] != len(timesteps) or lengths.shape != results.shape:
        return (
            f"{len(timesteps)} timesteps, results of shape {results.shape} and ep_lengths of shape "
            f"{lengths.shape} do not match"
        )
    return None


def read_evaluations(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The steps, per-episode returns and episode lengths of an ``evaluations.npz`` (SB3's layout).

    Raises:
        ValueError: the file does not hold them: empty, cut short, not an archive, or arrays of other names,
            types or shapes; the message says what is wrong.
    """
    try:
        with np.load(path, allow_pickle=False) as saved:
            arrays = tuple(np.asarray(saved[key]) for key in ("timesteps", "results", "ep_lengths"))
    except Exception as error:  # numpy and zipfile raise many types for a damaged file; all mean unreadable
        raise ValueError(f"{type(error).__name__}: {error}") from None
    problem = _evaluations_problem(*arrays)
    if problem is not None:
        raise ValueError(problem)
    return arrays


class ResumableEvalCallback(EvalCallback):
    """SB3's EvalCallback over all sessions of a run.

    A fresh EvalCallback overwrites ``evaluations.npz`` with the new session's evaluations and starts its best
    at −inf, so a resumed run forgot earlier evaluations and replaced a better best model with its first one.
    Resumed from step ``resume_step``, this one first loads the earlier evaluations up to that step (later
    ones belong to training that was lost with the unsaved steps, and are dropped) and starts from the best
    mean return recorded so far; ``best_model.zip`` is only replaced by a better model. ``evaluations.npz`` is
    written under a temporary name and renamed.

    Raises:
        ValueError: the earlier evaluations used another number of episodes (they could not share one array).
    """

    def __init__(self, eval_env: Any, files: RunFiles, resume_step: int | None, **kwargs: Any) -> None:
        super().__init__(
            eval_env,
            callback_on_new_best=SaveBestModel(files),
            log_path=str(files.run_dir),
            best_model_save_path=None,
            **kwargs,
        )
        self.files = files
        self.log_path = str(files.run_dir / "evaluations.tmp")  # np.savez adds ".npz"; renamed after each
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
        if not self.files.best_model.is_file():
            return
        if self.files.best_info.is_file() and self._best_mean_return() is None:
            aside = self.files.best_info.with_name(f"{self.files.best_info.stem}.unreadable.json")
            with naming_file(aside):
                os.replace(self.files.best_info, aside)
            print(f"warning: {self.files.best_info} unreadable; kept as {aside.name}, the best model's return "
                  "is taken from the evaluations")  # fmt: skip
        if not self.files.best_info.is_file() and earlier:
            # A run from before best_model.json: its best model's return is in the earlier evaluations.
            steps = read_saved_model(self.files.best_model).num_timesteps
            mean = earlier.get(steps, max(earlier.values()))
            write_text_atomically(self.files.best_info, json.dumps({"mean_return": mean, "timesteps": steps}))
        best = self._best_mean_return() if self.files.best_info.is_file() else None
        if best is not None:
            self.best_mean_reward = best

    def _best_mean_return(self) -> float | None:
        """The best model's mean return from ``best_model.json``; None when the file is damaged."""
        try:
            value = float(json.loads(self.files.best_info.read_text())["mean_return"])
        except (ValueError, KeyError, TypeError, UnicodeDecodeError):
            return None
        return value if np.isfinite(value) else None

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

    def _on_step(self) -> bool:
        evaluations_before = len(self.evaluations_timesteps)
        continue_training = super()._on_step()
        if len(self.evaluations_timesteps) > evaluations_before:
            with naming_file(self.files.evaluations):
                os.replace(f"{self.log_path}.npz", self.files.evaluations)
        return continue_training


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
