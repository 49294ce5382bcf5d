"""What the benchmark study chose, read from ``configs/studies.yaml`` (the one place it is written): the lever
search's winner, the planner's student, the flow gap's recipes and targets. The studies that decide on them and
the pages that word them (the winner is "the winner" in every report) read the same values from here.

Pure: it imports no policy, no env, no simulator.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

from agents.common.locations import REPO_ROOT
from agents.common.yaml_config import load_config

CHOICES_PATH = REPO_ROOT / "configs" / "studies.yaml"


@dataclass(frozen=True)
class BenchmarkChoices:
    """What the benchmark study chose (``configs/studies.yaml`` says what each is)."""

    winner: str
    student: str
    plain: list[str]
    truth_stages: list[str]
    gap_seeds: int
    max_failure: float
    oracle_factor: float
    max_rise: float
    robustness_speed: float
    robustness_density: float
    budget_minutes: float
    material: float
    thesis_max_relative: float
    centring_rules: list[str]
    speeds: list[float]
    descriptions: dict[str, str]
    factors: dict[str, list[str]]

    @property
    def truth_recipe(self) -> str:
        """The winner's recipe, both stages and the same budget, on the true depths at the same tracked points."""
        return f"{self.winner}_oracle"

    @property
    def student_truth(self) -> str:
        """The planner's student's recipe on the true depths at the same tracked points (privileged)."""
        return f"{self.student}_oracle"


@functools.cache
def choices(path: Path = CHOICES_PATH) -> BenchmarkChoices:
    """The study's choices, read once."""
    return load_config(path, BenchmarkChoices)
