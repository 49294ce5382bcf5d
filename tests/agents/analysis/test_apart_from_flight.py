"""The analysis reads committed episodes without the simulator: importing it loads no MuJoCo, Gymnasium or env
module (import-linter's contract in pyproject.toml checks the imports; this checks a real interpreter), and its
record outcome is the env's rule."""

from __future__ import annotations

import itertools
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from agents.analysis.episode_record import EPISODE_OUTCOMES, episode_outcome
from flownav_env import task

ANALYSIS = (
    "agents.analysis.csv_file",
    "agents.analysis.dose_response",
    "agents.analysis.earlier_rows",
    "agents.analysis.episode_record",
    "agents.analysis.over_seeds",
    "agents.analysis.paired",
    "agents.analysis.records",
    "agents.analysis.statistics",
    "agents.analysis.weaving",
)
ROOT = Path(__file__).resolve().parents[3]
FLIGHT = ("mujoco", "gymnasium", "flownav_env", "estimator", "cv2", "torch", "stable_baselines3")


@pytest.mark.parametrize("module", ANALYSIS)
def test_importing_the_analysis_loads_no_simulator(module: str) -> None:
    code = (
        f"import json, sys; import {module}; "
        f"print(json.dumps(sorted(m for m in sys.modules if m.split('.')[0] in {FLIGHT!r})))"
    )
    # This checkout's packages first, as pytest's own path has them.
    path = os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
    loaded = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "PYTHONPATH": path},
    )
    assert json.loads(loaded.stdout) == []


def test_the_record_outcome_is_the_envs_rule() -> None:
    assert EPISODE_OUTCOMES == task.EPISODE_OUTCOMES
    for flags in itertools.product((False, True), repeat=3):
        assert episode_outcome(*flags) == task.episode_outcome(*flags)


def test_the_typed_row_has_the_records_fields() -> None:
    from dataclasses import fields

    from agents.analysis.episode_record import EpisodeRecord, EpisodeRow

    assert list(EpisodeRow.__annotations__) == [item.name for item in fields(EpisodeRecord)]
