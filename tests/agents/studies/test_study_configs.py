"""The studies' choices as data (agents/studies/study_configs.py): the shipped configs load and are what the
committed reports were written with; a bad key or value is one line naming the file and the key."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import yaml

from agents.common.yaml_config import ConfigError, load_config
from agents.reports.regeneration import differences, regenerate
from agents.studies import rule_resolution, tier_calibration
from agents.studies.study_configs import (
    RULE_RESOLUTION_CONFIG,
    TIER_CALIBRATION_CONFIG,
    RuleResolutionConfig,
    TierCalibrationConfig,
    rule_resolution_config,
    tier_calibration_config,
)

Change = Callable[[dict[str, Any]], object]


def _refused(shipped: Path, schema: type, change: Change, tmp_path: Path) -> str:
    """The message of loading the shipped config ``shipped`` after ``change``, with its path as ``<config>``."""
    data = yaml.safe_load(shipped.read_text())
    change(data)
    path = tmp_path / shipped.name
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError) as error:
        load_config(path, schema)
    assert type(error.value) is ConfigError
    return str(error.value).replace(str(path), "<config>")


def test_the_shipped_configs_load_into_the_modules_names() -> None:
    study = rule_resolution_config()
    assert rule_resolution.RULES == ("bee_robust", "bee_ttc", "vfh") == tuple(study.rules)
    assert rule_resolution.TIERS == ("hard", "hard_noisy") and study.suite_version == "2"
    assert [r.name for r in rule_resolution.CANDIDATES] == ["3x10", "3x15", "3x15-9bins"]
    assert rule_resolution.REFINE_RULE == "bee_ttc"
    assert [r.name for r in rule_resolution.REFINE_CANDIDATES] == ["3x15-9bins", "3x5-9bins"]
    assert (study.layouts.search, study.layouts.refinement, study.layouts.confirmation) == (25, 50, 50)
    calibration = tier_calibration_config()
    assert tier_calibration.COURSE_AGENTS == tuple(calibration.course_agents)
    assert tier_calibration.TIER_AGENTS == tuple(calibration.tier_agents)
    assert calibration.calibrated_version == "1" and (calibration.layouts, calibration.runs) == (100, 5)
    assert calibration.target_failure == [0.2, 0.5]
    assert [(c["forward_speed"], c["obstacle_density"]) for c in calibration.courses] == [
        (speed, density) for speed in (1.5, 2.0, 2.5) for density in (0.12, 0.18, 0.24)
    ]


@pytest.mark.parametrize("name", ["rule-resolution", "calibrate-tiers"])
def test_the_committed_reports_are_what_the_shipped_configs_write(name: str, tmp_path: Path) -> None:
    (outcome,) = regenerate(tmp_path, [name])
    assert outcome.written is not None, outcome.skipped
    assert differences(outcome.report, outcome.written) == ""


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (
            lambda d: d.update(rulez=d.pop("rules")),
            "unknown key 'rulez' (allowed at top level: candidates, layouts, refine_candidates, refine_rule, "
            "rules, suite_version, tiers); did you mean 'rules'?",
        ),
        (lambda d: d["layouts"].update(search=0), "key 'layouts.search' must be in [1, 1000], got 0"),
        (
            lambda d: d.update(refine_rule="bee"),
            "key 'refine_rule' must be one of rules (bee_robust, bee_ttc, vfh), got 'bee'",
        ),
        (
            lambda d: d.update(rules=["bee_ttc", "ppo_flow"]),
            "key 'rules': 'ppo_flow' is not a rule (allowed: straight, bee, bee_robust, bee_ttc, vfh)",
        ),
        (
            lambda d: d.update(tiers=["hard", "harder"]),
            "key 'tiers': tier must be one of clean, hard, noisy, hard_noisy, got 'harder'; did you mean 'hard'?",
        ),
        (
            lambda d: d["candidates"].append({"sectors": [3, 5]}),
            "key 'candidates[3]': 3x5 is the rules' own resolution, not a candidate",
        ),
        (
            lambda d: d["refine_candidates"].append({"sectors": [3, 5], "bins": "fine"}),
            "key 'refine_candidates[2]': 3x5-9bins is a repeat, not a candidate",
        ),
        (
            lambda d: d["candidates"].append({"sectors": [3, 10], "bins": "coarse"}),
            "key 'candidates[3].bins' must be one of 'default', 'fine', got 'coarse'",
        ),
        (
            lambda d: d["candidates"].append({"sectors": [3]}),
            "key 'candidates[3]': sectors must be [rows, columns], got [3]",
        ),
    ],
)
def test_a_bad_rule_resolution_config_is_one_line_naming_the_key(
    change: Change, message: str, tmp_path: Path
) -> None:
    assert _refused(RULE_RESOLUTION_CONFIG, RuleResolutionConfig, change, tmp_path) == f"<config>: {message}"


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda d: d.update(layout=d.pop("layouts")), "unknown key 'layout' (allowed at top level: "),
        (lambda d: d.update(layouts=0), "key 'layouts' must be in [1, 10000], got 0"),
        (lambda d: d.update(runs=True), "key 'runs' must be an integer, got True"),
        (
            lambda d: d.update(target_failure=[0.2, 1.5]),
            "key 'target_failure' must be in [0.0, 1.0], got [0.2, 1.5]",
        ),
        (
            lambda d: d.update(target_failure=[0.5, 0.2]),
            "key 'target_failure' must be [low, high] with low < high, got [0.5, 0.2]",
        ),
        (
            lambda d: d["candidate_courses"].update(forward_speed=[1.5, -1.0]),
            "key 'candidate_courses.forward_speed': forward_speed must be in [0.0, 5.0], got -1.0",
        ),
        (
            lambda d: d.update(tier_agents=["bee", "bee"]),
            "key 'tier_agents' must be a non-empty list without repeats, got ['bee', 'bee']",
        ),
        (
            lambda d: d.update(course_agents=["bee", "nobody"]),
            "key 'course_agents': 'nobody' is not an agent",
        ),
        (
            lambda d: d.update(calibrated_version="3"),
            "key 'calibrated_version': suite version must be one of 1, 2, got '3'",
        ),
    ],
)
def test_a_bad_tier_calibration_config_is_one_line_naming_the_key(
    change: Change, message: str, tmp_path: Path
) -> None:
    found = _refused(TIER_CALIBRATION_CONFIG, TierCalibrationConfig, change, tmp_path)
    assert found.startswith(f"<config>: {message}") and "\n" not in found
