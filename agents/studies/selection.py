"""Choosing a finished run's policy among finalists on more layouts (``flownav select``).

Training keeps the model with the best mean return on its held-out evaluations, 10 episodes each at ~12 points
of a run. The best of a dozen noisy 10-episode means is often a lucky early one (the winner's curse): seed 0 of
``ppo_flow`` after the near-plane fix kept its 50,000-step model, 10 of 10 successes, over 300,000 steps of
training. Here the finalists (that model and the run's last checkpoint) each fly the same
:data:`FINALIST_EPISODES` fresh validation layouts of the run's own block, and the one with more successes
becomes the run's policy (a tie goes to the last checkpoint, which trained longest). Training is not touched.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

from agents.analysis.records import read_records
from agents.common.folders import copy_atomically, write_text_atomically
from agents.common.manifest import record_in_manifest
from agents.common.saved_models import latest_checkpoint
from agents.common.seeds import checkpoint_selection_seed
from agents.evaluation.episode_tasks import EpisodeTask, cached_file_sha256, rows_of, set_aside_stale_episodes
from agents.evaluation.runner import execute
from agents.training.outputs import RunFiles

FINALIST_EPISODES = 50
# Finalist layouts start this far into the run's checkpoint-selection block, past the layouts its training-time
# evaluations draw from (their env's random stream starts at the block's first seed).
FINALIST_SEED_OFFSET = 500
# Any learned agent name loads a staged policy (given by path) with the env settings of the config staged beside
# it; finalist k flies as "<label>@k", which keeps the finalists' episodes apart in the CSV.
_RUN_LABEL = "ppo_flow"


def finalist_seeds(run_seed: int, episodes: int = FINALIST_EPISODES) -> list[int]:
    """The validation layouts the finalists of training run ``run_seed`` fly."""
    first = checkpoint_selection_seed(run_seed) + FINALIST_SEED_OFFSET
    return list(range(first, first + episodes))


def finalists(files: RunFiles) -> dict[str, Path]:
    """The run's candidate policies: its best held-out model and its last checkpoint, where they exist."""
    candidates = {}
    if files.best_model.is_file():
        candidates["best held-out eval"] = files.best_model
    last = latest_checkpoint(files.checkpoints)
    if last is not None:
        candidates[f"last checkpoint ({last.stem})"] = last
    return candidates


def select_finalist(
    files: RunFiles, run_seed: int, *, workers: int = 2, episodes: int = FINALIST_EPISODES
) -> str:
    """Fly the run's finalists, make the one with more successes its policy and note it in its record.

    Resumable: the episodes go to ``<run>/finalists/episodes.csv``. Returns the record's ``selected`` line.

    Raises:
        FileNotFoundError: the run has no training config or no finalist (not trained, or trained elsewhere).
    """
    if not files.config.is_file():
        raise FileNotFoundError(f"{files.config} not found: {files.run_dir} is not a finished training run")
    candidates = finalists(files)
    by_content = {cached_file_sha256(path): label for label, path in reversed(list(candidates.items()))}
    # One candidate per content.
    candidates = {label: candidates[label] for label in reversed(list(by_content.values()))}
    if not candidates:
        raise FileNotFoundError(f"{files.run_dir} has no best model and no checkpoint to choose from")
    staging = files.run_dir / "finalists"
    staging.mkdir(exist_ok=True)
    seeds = finalist_seeds(run_seed, episodes)
    tasks, staged = [], {}
    for index, (label, source) in enumerate(candidates.items()):
        # Staged beside a copy of the run's config, so each loads as the policy it is (parameters only).
        staged[label] = staging / f"finalist_{index}.zip"
        shutil.copyfile(source, staged[label])
        shutil.copyfile(files.config, staged[label].with_suffix(".yaml"))
        agent = f"{_RUN_LABEL}@{index}"
        tasks += [EpisodeTask(agent, "clean", 0.0, seed, policy=str(staged[label])) for seed in seeds]
    # Copies of this run's own outputs, made just now: vouched for, so loading them does not warn.
    record_in_manifest(staging, [path.name for path in staged.values()])
    csv_path = staging / "episodes.csv"
    set_aside_stale_episodes(tasks, csv_path, "other finalists: the run trained on since; flying today's")
    execute(tasks, csv_path, workers=workers, description=f"{files.name} finalists")
    flown = rows_of(tasks, read_records(csv_path))
    successes = {
        label: sum(bool(row["success"]) for row in flown if row["agent"] == f"{_RUN_LABEL}@{index}")
        for index, label in enumerate(staged)
    }
    # Most successes; on a tie the later candidate (the last checkpoint, which trained longest).
    chosen = max(reversed(list(successes)), key=lambda label: successes[label])
    copy_atomically(staged[chosen], files.policy)
    scores = ", ".join(f"{label} {count}/{episodes}" for label, count in successes.items())
    selected = f"finalist on {episodes} validation layouts from {seeds[0]:,}: {chosen} ({scores})"
    _note_in_record(files, selected, successes, episodes)
    return selected


def _note_in_record(files: RunFiles, selected: str, successes: dict[str, int], episodes: int) -> None:
    record: dict[str, Any] = json.loads(files.record.read_text()) if files.record.is_file() else {}
    record["selected_in_training"] = record.get("selected_in_training", record.get("selected"))
    record["selected"] = selected
    record["finalists"] = {label: count / episodes for label, count in successes.items()}
    write_text_atomically(files.record, json.dumps(record, indent=2) + "\n")
