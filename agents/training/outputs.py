"""Where a training run's outputs lie: everything under ``runs/<name>/``, and the names they take once shipped
to ``results/policies/``.

A run never writes outside its own folder: shipping (:mod:`agents.training.shipping`) is a separate, deliberate
step, so that training, even a short test run, cannot replace a benchmarked policy by accident.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class RunFiles:
    """The files of the run ``name`` inside ``run_dir`` (``runs/<name>/``)."""

    run_dir: Path
    name: str

    @classmethod
    def of(cls, runs_dir: Path, name: str) -> RunFiles:
        """The run ``name`` under ``runs_dir``."""
        return cls(Path(runs_dir) / name, name)

    @classmethod
    def of_seed(cls, runs_dir: Path, name: str, seed: int) -> RunFiles:
        """Training seed ``seed`` of the run ``name``: ``runs_dir/<name>/seed_<seed>/seed_<seed>.zip`` etc.,
        shipped to ``<policies>/<name>/seed_<seed>.zip``."""
        return cls(Path(runs_dir) / name / f"seed_{seed}", f"seed_{seed}")

    @property
    def policy(self) -> Path:
        """The selected policy (best held-out evaluation, else the last model)."""
        return self.run_dir / f"{self.name}.zip"

    @property
    def config(self) -> Path:
        """A copy of the config YAML, beside the policy, so the policy's env settings travel with it."""
        return self.run_dir / f"{self.name}.yaml"

    @property
    def record(self) -> Path:
        """The training record (sessions, steps, machine, selection)."""
        return self.run_dir / f"{self.name}.json"

    def trained_steps(self) -> int:
        """The steps the record says were trained, with the policy written; 0 when either is missing (a run
        stopped before its first save, or another run's folder)."""
        if not (self.record.is_file() and self.policy.is_file()):
            return 0
        return int(json.loads(self.record.read_text()).get("total_timesteps", 0))

    @property
    def evaluations(self) -> Path:
        """Every held-out evaluation of every session (SB3's ``evaluations.npz`` layout)."""
        return self.run_dir / "evaluations.npz"

    @property
    def curve(self) -> Path:
        """The learning curve drawn from :attr:`evaluations`."""
        return self.run_dir / f"{self.name}_learning_curve.png"

    @property
    def checkpoints(self) -> Path:
        """Periodic checkpoints (``<name>_<steps>_steps.zip``), the resume points."""
        return self.run_dir / "checkpoints"

    @property
    def best_model(self) -> Path:
        """The model with the best held-out mean return so far, over all sessions."""
        return self.run_dir / "best" / "best_model.zip"

    @property
    def best_info(self) -> Path:
        """The best model's mean return and step count (JSON), so a resumed run knows what to beat."""
        return self.run_dir / "best" / "best_model.json"

    @property
    def tensorboard(self) -> Path:
        """TensorBoard logs."""
        return self.run_dir / "tb"

    def shipped_names(self) -> dict[Path, str]:
        """Each shippable file → its name in the policies folder (``ppo_flow_evaluations.npz`` etc.)."""
        return {
            self.policy: f"{self.name}.zip",
            self.config: f"{self.name}.yaml",
            self.record: f"{self.name}.json",
            self.evaluations: f"{self.name}_evaluations.npz",
            self.curve: f"{self.name}_learning_curve.png",
        }
