"""Carrying an unfinished training seed over to a new checkout (``flownav train --seeds ... --park``).

A run's folder lives under ``runs/``, which git ignores, so a run cut off by the end of a session is gone
from the next checkout with everything it learned. Parking copies what resuming needs (the newest readable
checkpoint, the held-out evaluations, the best model so far with its score, the record and the seed's
config; about 2 MB) to ``results/unfinished/<name>/seed_<k>/``, to be committed. ``flownav train --seeds``
restores a parked seed whose run folder has no checkpoint of its own, resumes it, and removes the parked copy
once the seed has finished.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from agents.common.locations import RESULTS_DIR
from agents.common.saved_models import latest_checkpoint
from agents.training.outputs import RunFiles

PARKED_DIR = RESULTS_DIR / "unfinished"


def parked_files(parked_dir: Path, name: str, seed: int) -> RunFiles:
    """Where training seed ``seed`` of config ``name`` is parked: the same layout as its run folder."""
    return RunFiles.of_seed(parked_dir, name, seed)


def _resume_state(files: RunFiles) -> list[Path]:
    """The files a resume reads, as they exist: newest readable checkpoint, evaluations, best model and score,
    record, config."""
    checkpoint = latest_checkpoint(files.checkpoints) if files.checkpoints.is_dir() else None
    wanted = [files.evaluations, files.best_model, files.best_info, files.record, files.config]
    return ([checkpoint] if checkpoint is not None else []) + [path for path in wanted if path.is_file()]


def _copy_state(source: RunFiles, target: RunFiles) -> list[Path]:
    copied = []
    for path in _resume_state(source):
        destination = target.run_dir / path.relative_to(source.run_dir)
        destination.parent.mkdir(parents=True, exist_ok=True)
        temporary = destination.with_name(f".{destination.name}.copying")
        shutil.copyfile(path, temporary)
        temporary.replace(destination)
        copied.append(destination)
    return copied


def park(files: RunFiles, parked: RunFiles) -> list[Path]:
    """Copy the resume state of the run ``files`` to ``parked`` (replacing an older parked copy); returns the
    copied paths.

    Raises:
        FileNotFoundError: the run has no readable checkpoint, so there is nothing to resume from.
    """
    if not files.checkpoints.is_dir() or latest_checkpoint(files.checkpoints) is None:
        raise FileNotFoundError(f"{files.run_dir} has no readable checkpoint: nothing to park")
    if parked.run_dir.exists():
        shutil.rmtree(parked.run_dir)
    return _copy_state(files, parked)


def restore(parked: RunFiles, files: RunFiles) -> bool:
    """Copy a parked seed back into its run folder when that holds no checkpoint; whether it did."""
    if files.checkpoints.is_dir() and latest_checkpoint(files.checkpoints) is not None:
        return False
    if not parked.checkpoints.is_dir() or latest_checkpoint(parked.checkpoints) is None:
        return False
    _copy_state(parked, files)
    return True


def discard(parked: RunFiles) -> None:
    """Remove a parked copy (its seed has finished), and its config's folder once no seed is left in it."""
    if parked.run_dir.exists():
        shutil.rmtree(parked.run_dir)
    config_dir = parked.run_dir.parent
    if config_dir.is_dir() and not any(config_dir.iterdir()):
        config_dir.rmdir()
