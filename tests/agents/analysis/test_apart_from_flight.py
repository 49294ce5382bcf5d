"""The analysis reads committed episodes without the simulator: importing it loads no MuJoCo, Gymnasium or env
module (import-linter's contract in pyproject.toml checks the imports; this checks a real interpreter), and its
record outcome is the env's rule."""

from __future__ import annotations

import itertools

import pytest
from helpers import flight_modules_loaded_by

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


@pytest.mark.parametrize("module", ANALYSIS)
def test_importing_the_analysis_loads_no_simulator(module: str) -> None:
    assert flight_modules_loaded_by(module) == []


def test_the_record_outcome_is_the_envs_rule() -> None:
    assert EPISODE_OUTCOMES == task.EPISODE_OUTCOMES
    for flags in itertools.product((False, True), repeat=3):
        assert episode_outcome(*flags) == task.episode_outcome(*flags)


def test_the_typed_row_has_the_records_fields_and_types() -> None:
    from dataclasses import MISSING, fields

    from agents.analysis.episode_record import EpisodeRecord, EpisodeRow

    assert list(EpisodeRow.__annotations__) == [item.name for item in fields(EpisodeRecord)]
    for item in fields(EpisodeRecord):
        # A column with a default came after the first files: reading one of those leaves it None (unknown).
        known = item.type if item.default is MISSING else f"{item.type} | None"
        assert EpisodeRow.__annotations__[item.name].__forward_arg__ == known, item.name
