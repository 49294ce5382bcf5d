"""A stable-baselines3 model of any algorithm, trained outside FlowNav, scored from its parameters alone."""

from __future__ import annotations

import base64
import json
import os
import pickle
import re
import zipfile
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import flownav_env  # noqa: F401
from agents.analysis.records import read_records
from agents.cli import main
from agents.policies import agent_env_kwargs, agent_parameters, load_agent
from agents.policies.external import display_name
from agents.policies.sb3_models import sb3_model_name

SMALL = {"camera_width": 96, "camera_height": 72}


def saved_model(algo: str, directory: Path, **env_settings: bool) -> Path:
    from stable_baselines3 import A2C, SAC

    env = gym.make("FlowNavSingle-v0", **SMALL, **env_settings)
    options = {
        "sac": (SAC, {"learning_starts": 0, "buffer_size": 64, "batch_size": 4}),
        "a2c": (A2C, {"n_steps": 4}),
    }
    algorithm_class, extra = options[algo]
    model = algorithm_class("MultiInputPolicy", env, seed=0, policy_kwargs={"net_arch": [8]}, **extra)
    model.learn(8)
    path = directory / f"{algo}_model.zip"
    model.save(path)
    env.close()
    return path


@pytest.mark.parametrize("algo", ["sac", "a2c"])
def test_a_model_acts_as_its_algorithm_loads_it(algo: str, tmp_path: Path) -> None:
    from stable_baselines3 import A2C, SAC

    path = saved_model(algo, tmp_path)
    agent = load_agent(sb3_model_name(algo, path))
    env = gym.make("FlowNavSingle-v0", **SMALL)
    observation, _ = env.reset(seed=1_000_000)
    env.close()
    expected, _ = {"sac": SAC, "a2c": A2C}[algo].load(path).predict(observation, deterministic=True)
    action, _ = agent.predict(observation, deterministic=True)
    np.testing.assert_allclose(action, expected, rtol=1e-6)
    assert agent_parameters(sb3_model_name(algo, path))["algo"] == algo


def test_a_model_reading_an_optional_key_flies_with_the_setting_that_gives_it(tmp_path: Path) -> None:
    path = saved_model("sac", tmp_path, observe_approach=True)
    assert agent_env_kwargs(sb3_model_name("sac", path)) == {"observe_approach": True}


def test_policy_kwargs_naming_other_code_are_refused_without_trust_pickle(tmp_path: Path) -> None:
    path = saved_model("sac", tmp_path)
    marker = tmp_path / "ran"
    crafted = tmp_path / "crafted.zip"

    class RunsCode:
        def __reduce__(self):
            return (os.mkdir, (str(marker),))

    with zipfile.ZipFile(path) as source, zipfile.ZipFile(crafted, "w") as target:
        for item in source.infolist():
            content = source.read(item)
            if item.filename == "data":
                data = json.loads(content)
                data["policy_kwargs"] = {
                    ":serialized:": base64.b64encode(pickle.dumps({"x": RunsCode()})).decode()
                }
                content = json.dumps(data).encode()
            target.writestr(item, content)
    with pytest.raises(ValueError, match=r"policy_kwargs are pickled .* pass --trust-pickle"):
        load_agent(sb3_model_name("sac", crafted))
    assert not marker.exists()


def test_evaluate_scores_a_model_given_by_policy_and_algo(tmp_path: Path) -> None:
    path = saved_model("sac", tmp_path)
    out = tmp_path / "episodes.csv"
    options = [
        "--layouts",
        "1",
        "--tiers",
        "FlowNavSingle-v0",
        "--env",
        "camera_width=96",
        "--env",
        "camera_height=72",
    ]
    assert main(["evaluate", "--policy", str(path), "--algo", "sac", "--out", str(out), *options]) == 0
    (row,) = read_records(out)
    assert row["agent"] == f"sac:{path.resolve()}"
    assert "model_sha256" in json.loads(row["agent_params"])


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        (["--algo", "sac"], "--algo goes with --policy model.zip and without --agent"),
        (
            ["--algo", "sac", "--agent", "bee", "--policy", "x.zip"],
            "--algo goes with --policy model.zip and without",
        ),
        ([], "give --agent \\(or --policy model.zip --algo ALGO\\)"),
    ],
)
def test_evaluate_refuses_an_incomplete_model_request(arguments: list[str], message: str, capsys) -> None:
    assert main(["evaluate", *arguments]) == 2
    assert re.search(message, capsys.readouterr().err)


@pytest.mark.parametrize("algo", ["sac", "a2c"])
def test_a_saved_model_is_scored_on_the_suite(algo: str, tmp_path: Path) -> None:
    from agents.evaluation.suite_report import read_suite_csv

    path = saved_model(algo, tmp_path)
    out = tmp_path / "score"
    argv = [
        "score",
        "--policy",
        str(path),
        "--algo",
        algo,
        "--tiers",
        "hard",
        "--layouts",
        "1",
        "--workers",
        "1",
    ]
    assert main([*argv, "--out", str(out)]) == 0
    (row,) = read_suite_csv(out / "score.csv")
    assert row["agent"] == display_name(sb3_model_name(algo, path)) == f"{algo}:{path.stem}"
    assert row["tier"] == "hard" and row["episodes"] == 1
