"""The callbacks of a training run: atomic checkpoints, an evaluation whose history and best model carry
over a resume, a wall-clock budget, and progress lines for runs that share a terminal."""

from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback, CheckpointCallback, EvalCallback

from agents.training.outputs import RunFiles
from agents.training.saved_models import read_saved_model, save_atomically


class AtomicCheckpointCallback(CheckpointCallback):
    """SB3's CheckpointCallback, but each checkpoint is written under a temporary name and renamed, so a
    crash mid-save never leaves a truncated newest checkpoint for ``--resume`` to trip on."""

    def _on_step(self) -> bool:
        if self.n_calls % self.save_freq == 0:
            save_atomically(self.model, Path(self._checkpoint_path(extension="zip")))
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
        temporary = self.files.best_info.with_suffix(".tmp")
        temporary.write_text(json.dumps(info))
        os.replace(temporary, self.files.best_info)
        return True


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
        if self.files.evaluations.is_file():
            try:
                with np.load(self.files.evaluations) as saved:
                    timesteps, results, lengths = saved["timesteps"], saved["results"], saved["ep_lengths"]
            except (OSError, ValueError, KeyError) as error:
                print(f"warning: earlier evaluations unreadable, starting a new history: {error}")
            else:
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
        if not self.files.best_info.is_file() and earlier:
            # A run from before best_model.json: its best model's return is in the earlier evaluations.
            steps = read_saved_model(self.files.best_model).num_timesteps
            mean = earlier.get(steps, max(earlier.values()))
            self.files.best_info.write_text(json.dumps({"mean_return": mean, "timesteps": steps}))
        if self.files.best_info.is_file():
            self.best_mean_reward = float(json.loads(self.files.best_info.read_text())["mean_return"])

    def _on_step(self) -> bool:
        evaluations_before = len(self.evaluations_timesteps)
        continue_training = super()._on_step()
        if len(self.evaluations_timesteps) > evaluations_before:
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
