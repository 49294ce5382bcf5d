"""flownav_env.settings_check: the one validator of FlowNav settings by name, shared by FlowNavEnv's keywords,
gymnasium.make and the YAML configs, which checks without building an env."""

from __future__ import annotations

import gymnasium as gym
import pytest

import flownav_env.env
from flownav_env import FlowNavEnv
from flownav_env.settings import EnvSettings
from flownav_env.settings_check import ENV_ARGUMENTS, check_env_kwargs, setting_check

SMALL = {"camera_width": 64, "camera_height": 48}


@pytest.mark.parametrize(
    ("env_kwargs", "key", "message"),
    [
        ({"wind": 3}, "env", r"^run\.yaml: unknown key 'env\.wind' \(not a FlowNavEnv argument\)$"),
        (
            {"forward_speed": -1},
            "env",
            r"^run\.yaml: key 'env\.forward_speed': forward_speed must be in \[0\.0, 5\.0\], got -1$",
        ),
        (
            {"histogram_sectors": [3, 40]},
            "env",
            r"^run\.yaml: key 'env\.histogram_sectors\[1\]': histogram_sectors\[1\] must be an integer in",
        ),
        (
            {"estimator_kwargs": {"fast_threshold": 0}},
            "env",
            r"^run\.yaml: key 'env\.fast_threshold': fast_threshold must be an integer with 1 <= ",
        ),
        (
            {"render_mode": "human"},
            "--env",
            r"^run\.yaml: key '--env\.render_mode': render_mode must be one of 'rgb_array', got 'human'$",
        ),
        (
            {"flight_height": 2.0, "max_height": 1.5},
            "env",
            r"^run\.yaml: key 'env\.max_height': max_height must be in \(2\.0, 20\.0\], got 1\.5$",
        ),
    ],
)
def test_check_env_kwargs_names_the_source_the_key_and_the_rule(env_kwargs, key, message) -> None:
    with pytest.raises(ValueError, match=message):
        check_env_kwargs(env_kwargs, "run.yaml", key=key)


def test_check_env_kwargs_builds_no_env(monkeypatch: pytest.MonkeyPatch) -> None:
    def no_world(*args, **kwargs):
        raise AssertionError("check_env_kwargs built a MuJoCo world")

    monkeypatch.setattr(flownav_env.env, "FlowNavPhysics", no_world)
    monkeypatch.setattr(flownav_env.env, "CameraRenderer", no_world)
    env_kwargs = {"forward_speed": 2, "render_mode": "rgb_array", "estimator_kwargs": {"fast_threshold": 5}}
    assert check_env_kwargs(env_kwargs, "run.yaml") == env_kwargs
    assert set(ENV_ARGUMENTS) == {"render_mode", *EnvSettings.__dataclass_fields__}


def test_setting_check_checks_a_value_or_each_of_a_list() -> None:
    check = setting_check("rotation_error")
    assert check("levels", 0.5) == 0.5 and check("levels", [0, 0.1]) == [0.0, 0.1]
    with pytest.raises(ValueError, match=r"^rotation_error must be in \[0\.0, 1\.0\], got 2$"):
        check("levels", [0.1, 2])
    # A (rows, cols) setting's own value is a pair: checked whole, not item by item.
    assert setting_check("histogram_sectors")("sectors", [2, 4]) == (2, 4)
    with pytest.raises(ValueError, match=r"^unknown setting 'rotation_eror'; known: .* \(did you mean"):
        setting_check("rotation_eror")


def test_the_env_takes_whole_settings_and_overrides_by_keyword() -> None:
    settings = EnvSettings(**SMALL, forward_speed=2.0, rotation_error=0.1)
    env = FlowNavEnv(settings, forward_speed=1.5)
    assert env.settings == EnvSettings(**SMALL, forward_speed=1.5, rotation_error=0.1)
    assert env.intrinsics.width == 64 and env.rotation_error == 0.1
    env.close()
    env = gym.make("FlowNavThree-v0", settings=EnvSettings(**SMALL, layout="three"))
    assert env.unwrapped.settings.camera_width == 64
    env.close()
    env = gym.make("FlowNav-v0", rotation_error=0.05, **SMALL)
    assert env.unwrapped.rotation_error == 0.05
    env.close()


def test_an_unknown_keyword_names_itself_and_the_known_settings() -> None:
    message = (
        r"^FlowNavEnv takes settings=, render_mode= and settings by name: unknown setting 'rotation_eror'; "
        r"known: attitude_jitter_deg, brightness, rotation_error, .*, estimator_kwargs "
        r"\(did you mean 'rotation_error'\?\)$"
    )
    with pytest.raises(ValueError, match=message):
        FlowNavEnv(rotation_eror=0.1)
    with pytest.raises(ValueError, match=r"unknown setting 'nonsense'; known: attitude_jitter_deg, "):
        gym.make("FlowNav-v0", nonsense=1)
    with pytest.raises(
        ValueError, match=r"^settings must be a flownav_env\.settings\.EnvSettings or None, got str"
    ):
        FlowNavEnv("corridor")


def test_gym_make_refuses_settings_of_another_layout_than_the_ids() -> None:
    with pytest.raises(
        ValueError,
        match=r"^settings\.layout is 'three' but this env id flies layout 'field': make FlowNavThree-v0 or "
        r"pass layout='three' as well$",
    ):
        gym.make("FlowNav-v0", settings=EnvSettings(layout="three"))
