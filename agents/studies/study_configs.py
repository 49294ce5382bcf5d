"""The choices of two studies as data: ``configs/studies/rule_resolution.yaml`` (:mod:`agents.studies.rule_resolution`)
and ``configs/studies/tier_calibration.yaml`` (:mod:`agents.studies.tier_calibration`), each read onto a frozen
dataclass and validated on load (:func:`agents.common.yaml_config.load_config`: a bad key or value is one line
naming the file and the key). Their layouts' seed ranges stay in :mod:`agents.common.seeds`.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from agents.common.locations import CONFIGS_DIR
from agents.common.seeds import (
    RULE_RESOLUTION_LAYOUTS,
    SENSOR_PILOT_SEED_START,
    TIER_CALIBRATION_SEED_START,
)
from agents.common.yaml_config import checked_field, field_range, load_config
from agents.policies.base import AGENT_NAMES, REACTIVE_AGENTS
from agents.policies.histogram_resolution import FINE_BIN_EDGES, HistogramResolution
from flownav_env.settings_check import setting_check
from flownav_env.tiers import tier

STUDY_CONFIGS = CONFIGS_DIR / "studies"
RULE_RESOLUTION_CONFIG = STUDY_CONFIGS / "rule_resolution.yaml"
TIER_CALIBRATION_CONFIG = STUDY_CONFIGS / "tier_calibration.yaml"


@dataclass(frozen=True)
class ResolutionChoice:
    """A depth histogram resolution as a config names it: sector rows and columns, and the depth bins (the
    env's default or the flow student's fine ones, :data:`~agents.policies.histogram_resolution.FINE_BIN_EDGES`)."""

    sectors: list[int]
    bins: Literal["default", "fine"] = "default"

    @property
    def resolution(self) -> HistogramResolution:
        """The resolution this names.

        Raises:
            ValueError: sectors that are not [rows, columns], or that the env refuses.
        """
        if len(self.sectors) != 2:
            raise ValueError(f"sectors must be [rows, columns], got {self.sectors!r}")
        rows, columns = self.sectors
        if self.bins == "fine":
            return HistogramResolution((rows, columns), FINE_BIN_EDGES)
        return HistogramResolution((rows, columns))


@dataclass(frozen=True)
class StageLayouts:
    """Validation layouts per tier of each stage of the rule-resolution study."""

    search: int = field_range(1, RULE_RESOLUTION_LAYOUTS)
    refinement: int = field_range(1, RULE_RESOLUTION_LAYOUTS)
    confirmation: int = field_range(1, RULE_RESOLUTION_LAYOUTS)


@dataclass(frozen=True)
class RuleResolutionConfig:
    """The rule-resolution study's choices (``configs/studies/rule_resolution.yaml`` says what each is)."""

    rules: list[str]
    suite_version: str
    tiers: list[str]
    candidates: list[ResolutionChoice]
    refine_rule: str
    refine_candidates: list[ResolutionChoice]
    layouts: StageLayouts

    def validate(self) -> None:
        _check_names("rules", self.rules, REACTIVE_AGENTS, "a rule")
        _check_names("tiers", self.tiers, (), "a tier")
        for name in self.tiers:
            try:
                tier(name, self.suite_version)
            except ValueError as error:
                raise ValueError(f"key 'tiers': {error}") from None
        if self.refine_rule not in self.rules:
            raise ValueError(
                f"key 'refine_rule' must be one of rules ({', '.join(self.rules)}), got {self.refine_rule!r}"
            )
        for key in ("candidates", "refine_candidates"):
            _resolutions(key, getattr(self, key))

    @property
    def candidate_resolutions(self) -> tuple[HistogramResolution, ...]:
        """The search's candidates, in the config's order."""
        return _resolutions("candidates", self.candidates)

    @property
    def refine_resolutions(self) -> tuple[HistogramResolution, ...]:
        """The refinement's candidates, in the config's order."""
        return _resolutions("refine_candidates", self.refine_candidates)


@dataclass(frozen=True)
class CandidateCourses:
    """The candidate hard courses: every forward speed with every obstacle density."""

    forward_speed: list[float] = checked_field(setting_check("forward_speed"))
    obstacle_density: list[float] = checked_field(setting_check("obstacle_density"))


@dataclass(frozen=True)
class TierCalibrationConfig:
    """Suite v1's tier calibration (``configs/studies/tier_calibration.yaml`` says what each is)."""

    calibrated_version: str
    candidate_courses: CandidateCourses
    course_agents: list[str]
    tier_agents: list[str]
    # At most the layouts before the next seed range (the sensor pilot's) begins.
    layouts: int = field_range(1, SENSOR_PILOT_SEED_START - TIER_CALIBRATION_SEED_START)
    runs: int = field_range(1, None)
    target_failure: list[float] = field_range(0.0, 1.0)

    def validate(self) -> None:
        try:
            tier("clean", self.calibrated_version)
        except ValueError as error:
            raise ValueError(f"key 'calibrated_version': {error}") from None
        for key in ("course_agents", "tier_agents"):
            _check_names(key, getattr(self, key), AGENT_NAMES, "an agent")
        for key, values in vars(self.candidate_courses).items():
            if not values or len(set(values)) != len(values):
                raise ValueError(f"key 'candidate_courses.{key}' must be a non-empty list without repeats")
        low_high = self.target_failure
        if len(low_high) != 2 or low_high[0] >= low_high[1]:
            raise ValueError(f"key 'target_failure' must be [low, high] with low < high, got {low_high!r}")

    @property
    def courses(self) -> tuple[dict[str, float], ...]:
        """Every candidate course, speed by speed, each density within a speed."""
        return tuple(
            {"forward_speed": speed, "obstacle_density": density}
            for speed in self.candidate_courses.forward_speed
            for density in self.candidate_courses.obstacle_density
        )


def _check_names(key: str, names: Sequence[str], allowed: Sequence[str], what: str) -> None:
    """``names`` is a non-empty list without repeats, each in ``allowed`` (when given).

    Raises:
        ValueError: one line naming ``key``.
    """
    if not names or len(set(names)) != len(names):
        raise ValueError(f"key '{key}' must be a non-empty list without repeats, got {list(names)!r}")
    unknown = [name for name in names if allowed and name not in allowed]
    if unknown:
        raise ValueError(f"key '{key}': {unknown[0]!r} is not {what} (allowed: {', '.join(allowed)})")


def _resolutions(key: str, choices: Sequence[ResolutionChoice]) -> tuple[HistogramResolution, ...]:
    """The resolutions ``choices`` name: a non-empty list without repeats, none the env's default (each
    candidate is compared with it).

    Raises:
        ValueError: one line naming ``key`` and the index.
    """
    found: list[HistogramResolution] = []
    for index, choice in enumerate(choices):
        try:
            resolution = choice.resolution
        except ValueError as error:
            raise ValueError(f"key '{key}[{index}]': {error}") from None
        if resolution == HistogramResolution() or resolution in found:
            what = "a repeat" if resolution in found else "the rules' own resolution"
            raise ValueError(f"key '{key}[{index}]': {resolution.name} is {what}, not a candidate")
        found.append(resolution)
    if not found:
        raise ValueError(f"key '{key}' must name at least one resolution")
    return tuple(found)


@functools.cache
def rule_resolution_config(path: Path = RULE_RESOLUTION_CONFIG) -> RuleResolutionConfig:
    """The rule-resolution study's choices, read once."""
    return load_config(path, RuleResolutionConfig)


@functools.cache
def tier_calibration_config(path: Path = TIER_CALIBRATION_CONFIG) -> TierCalibrationConfig:
    """Suite v1's tier calibration choices, read once."""
    return load_config(path, TierCalibrationConfig)
