"""A training config's finished seeds as a comparison flies them: where each seed's files are (its run folder or
its shipped copy), its evaluations during training, and how it was trained (from its training record)."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

from agents.common.yaml_config import load_config
from agents.evaluation.episode_tasks import cached_file_sha256
from agents.training.outputs import RunFiles
from agents.training.train_config import TrainConfig, for_tier


def recipe_on_tier(config_path: Path, tier: str | None) -> TrainConfig | str:
    """The config at ``config_path`` as flown on ``tier``: a recipe for every tier (``per_tier: true``) as that
    tier's runs (``<name>_<tier>``, :func:`~agents.training.train_config.for_tier`); without a tier to choose
    them, such a recipe's name instead."""
    config = load_config(config_path, TrainConfig)
    if not config.per_tier:
        return config
    return config.name if tier is None else for_tier(config, tier, str(config_path))


def seed_files(
    runs_dir: Path, policies_dir: Path | None, name: str, seed: int, total_timesteps: int
) -> RunFiles | None:
    """The files of finished training seed ``seed`` of config ``name``: its shipped files (``<policies_dir>/
    <name>/seed_<k>.*``, the same names without the run folder) unless its run folder holds another finished
    policy (it trained on or was selected since shipping), then the run folder's; None when neither holds a
    finished one. A run folder stopped short of ``total_timesteps`` never counts: its policy is whatever the
    interruption saved. The shipped copy is the one its folder's manifest vouches for."""
    run = RunFiles.of_seed(runs_dir, name, seed)
    run_finished = run.trained_steps() >= total_timesteps
    shipped = RunFiles(Path(policies_dir) / name, run.name) if policies_dir is not None else None
    if shipped is not None and shipped.policy.is_file():
        if not run_finished or cached_file_sha256(run.policy) == cached_file_sha256(shipped.policy):
            return shipped
    return run if run_finished else None


def evaluations_file(files: RunFiles) -> Path | None:
    """A seed's evaluations during training: in its run folder, or for a shipped seed beside its policy."""
    evaluations = files.evaluations
    if not evaluations.is_file():
        evaluations = files.run_dir / files.shipped_names()[files.evaluations]
    return evaluations if evaluations.is_file() else None


def how_trained(
    trained: Sequence[tuple[int, RunFiles]],
) -> tuple[tuple[str, ...], tuple[tuple[int, float], ...]]:
    """From the training records of a config's flown seeds: the distinct commands that trained them, and each
    seed's training minutes (its sessions' wall time)."""
    commands: list[str] = []
    minutes: list[tuple[int, float]] = []
    for seed, files in trained:
        sessions = training_sessions(files)
        for command in (str(session.get("command") or "") for session in sessions):
            if command and command not in commands:
                commands.append(command)
        walls = (session.get("wall_minutes") for session in sessions)
        minutes.append((seed, sum(float(wall) for wall in walls if isinstance(wall, int | float))))
    return tuple(commands), tuple(minutes)


def training_sessions(files: RunFiles) -> list[dict[str, object]]:
    """The sessions of a seed's training record (each its command and wall minutes), in its run folder or, for
    a shipped seed, beside its policy; empty without one."""
    record = files.record
    if not record.is_file():
        record = files.run_dir / files.shipped_names()[files.record]
    if not record.is_file():
        return []
    return list(json.loads(record.read_text()).get("sessions", []))
