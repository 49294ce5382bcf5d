"""The sweep's factors: one env setting each, or the noisy tiers' velocity error, which takes two."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from agents.common.yaml_config import ConfigError, load_config
from agents.evaluation.sweep import SweepConfig, build_tasks
from agents.evaluation.sweep_factors import (
    COMPOSITE_FACTORS,
    SETTING_FACTORS,
    SWEEP_FACTORS,
    TIER_VELOCITY_CORRELATION_S,
    TIER_VELOCITY_SIGMA_M_S,
    factor_settings,
)
from flownav_env.sensor_specs import flight_stack_sensor
from flownav_env.settings import SensorSettings


def test_a_setting_factor_is_its_own_setting() -> None:
    assert factor_settings("depth_noise", 0.2) == {"depth_noise": 0.2}
    assert set(SWEEP_FACTORS) == set(SETTING_FACTORS) | set(COMPOSITE_FACTORS)
    sensor_fields = set(SensorSettings.__dataclass_fields__)
    assert {f for f in SETTING_FACTORS if f not in ("forward_speed", "obstacle_density")} <= sensor_fields


def test_the_velocity_factors_hold_the_other_half_at_the_noisy_tiers_reading() -> None:
    tier = flight_stack_sensor()
    at_reading = factor_settings("velocity_error_m_s", TIER_VELOCITY_SIGMA_M_S)
    assert at_reading == {
        "translation_noise_m": tier["translation_noise_m"],
        "translation_noise_correlation_s": tier["translation_noise_correlation_s"],
    }
    assert factor_settings("velocity_correlation_s", TIER_VELOCITY_CORRELATION_S) == at_reading
    assert factor_settings("velocity_error_m_s", 1.0)["translation_noise_m"] == pytest.approx(0.1)
    white = factor_settings("velocity_correlation_s", 0.0)
    assert white["translation_noise_correlation_s"] == 0.0
    assert white["translation_noise_m"] == tier["translation_noise_m"]


@pytest.mark.parametrize(
    ("factor", "level", "message"),
    [
        ("wind", 1.0, r"not a sweep factor: 'wind' \(allowed: rotation_error, "),
        ("velocity_error_m_s", -0.1, r"velocity_error_m_s must be a number >= 0, got -0.1"),
        ("velocity_correlation_s", True, r"velocity_correlation_s must be a number >= 0, got True"),
        ("depth_dropout", 1.5, r"depth_dropout must be in \[0.0, 1.0\], got 1.5"),
    ],
)
def test_bad_factors_and_levels_are_refused_naming_them(factor: str, level: float, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        factor_settings(factor, level)


def test_a_composite_level_out_of_its_settings_range_names_the_config_key(tmp_path: Path) -> None:
    path = tmp_path / "sweep.yaml"
    path.write_text(
        yaml.safe_dump({"agents": ["bee"], "factors": {"velocity_error_m_s": [0.1, 1e6]}}),
    )
    with pytest.raises(
        ConfigError, match=r"key 'factors.velocity_error_m_s\[1\]': translation_noise_m must be"
    ):
        load_config(path, SweepConfig)


def test_a_composite_cell_flies_both_settings_on_top_of_the_sweeps_own(tmp_path: Path) -> None:
    path = tmp_path / "sweep.yaml"
    path.write_text(
        yaml.safe_dump(
            {
                "agents": ["bee"],
                "env": {"camera_width": 96},
                "episodes": 1,
                "factors": {"velocity_correlation_s": [10.0]},
            }
        )
    )
    config = load_config(path, SweepConfig)
    clean, cell = build_tasks(config, config.agents)
    assert dict(clean.env_kwargs) == {"camera_width": 96}
    assert (cell.factor, cell.level) == ("velocity_correlation_s", 10.0)
    assert dict(cell.env_kwargs) == {"camera_width": 96, **factor_settings("velocity_correlation_s", 10.0)}


def test_an_agent_learned_per_tier_flies_the_policy_of_the_tier_swept(tmp_path: Path) -> None:
    policies = tmp_path / "policies"
    agent = "ppo_flow_camera_student_fine_rounds6"
    for tier in ("clean", "hard"):
        (policies / f"{agent}_{tier}").mkdir(parents=True)
        (policies / f"{agent}_{tier}" / "seed_0.zip").write_bytes(b"")
    for env_id, tier in (("FlowNav-v1", "clean"), ("FlowNavHard-v1", "hard")):
        path = tmp_path / f"{tier}.yaml"
        path.write_text(
            yaml.safe_dump(
                {
                    "agents": [f"{agent}@all"],
                    "env_id": env_id,
                    "episodes": 1,
                    "policy_dir": str(policies),
                    "factors": {},
                }
            )
        )
        config = load_config(path, SweepConfig)
        (task,) = build_tasks(config, config.agents)
        assert task.policy == str(policies / f"{agent}_{tier}" / "seed_0.zip")
