"""Agents written outside FlowNav: named by module or file, scored like shipped ones, bad ones refused in one line."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import flownav_env  # noqa: F401
from agents.analysis.records import read_records
from agents.cli import main
from agents.evaluation.episode import run_episode
from agents.policies import agent_env_kwargs, agent_parameters, load_agent

SMALL = {"camera_width": 96, "camera_height": 72}
AGENT_SOURCE = '''
import numpy as np

class Centre:
    """Steers away from the nearer side, as a user's hand-written rule might."""

    env_settings = {"observe_nearness": True}

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        nearness = np.asarray(observation["nearness"], np.float64).reshape(-1)
        half = len(nearness) // 2
        turn = float(np.clip(nearness[:half].mean() - nearness[-half:].mean(), -1, 1))
        return np.array([turn, 0.0, 0.0], np.float32), state

def make_agent():
    return Centre()

AGENT = Centre()
NOT_AN_AGENT = 42

def make_nothing():
    return "no predict here"

class Greedy:
    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        return np.zeros(3, np.float32) + observation["approach"].mean(), state
'''


@pytest.fixture
def agent_file(tmp_path: Path) -> Path:
    path = tmp_path / "my_agent.py"
    path.write_text(AGENT_SOURCE)
    return path


def test_an_agent_from_a_file_flies_with_the_settings_it_declares(agent_file: Path) -> None:
    spec = f"{agent_file}:make_agent"
    assert agent_env_kwargs(spec) == {"observe_nearness": True}
    env = gym.make("FlowNavSingle-v0", **SMALL, **agent_env_kwargs(spec))
    try:
        record = run_episode(env, load_agent(spec), seed=1_000_000, label=spec)
    finally:
        env.close()
    assert record.agent == spec and record.steps > 0


def test_an_object_with_predict_is_the_agent_itself(agent_file: Path) -> None:
    observation = {"nearness": np.zeros(15, np.float32)}
    action, _ = load_agent(f"{agent_file}:AGENT").predict(observation)
    assert action.shape == (3,)


def test_an_agent_from_an_importable_module(agent_file: Path, monkeypatch) -> None:
    monkeypatch.syspath_prepend(str(agent_file.parent))
    monkeypatch.delitem(sys.modules, "my_agent", raising=False)
    action, _ = load_agent("my_agent:make_agent").predict({"nearness": np.zeros(15, np.float32)})
    assert action.shape == (3,)


def test_records_identify_the_agent_by_the_hash_of_its_file(agent_file: Path) -> None:
    before = agent_parameters(f"{agent_file}:make_agent")["source_sha256"]
    assert len(before) == 64


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("no_such_module_anywhere:make_agent", "cannot import the agent module 'no_such_module_anywhere'"),
        ("{dir}/missing.py:make_agent", "agent file .*missing.py not found"),
        ("{file}:no_such_name", "my_agent.py has no 'no_such_name'"),
        ("{file}:make_nothing", "gave a str, which has no predict"),
        ("{file}:NOT_AN_AGENT", "gave a int, which has no predict"),
        ("{file}:", "expected module.path:callable or path/to/file.py:callable"),
    ],
)
def test_bad_agents_are_one_clear_error(agent_file: Path, spec: str, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        load_agent(spec.format(dir=agent_file.parent, file=agent_file))


def test_an_agent_reading_a_key_the_env_lacks_is_told_which_setting_gives_it(agent_file: Path) -> None:
    agent = load_agent(f"{agent_file}:Greedy")
    with pytest.raises(
        ValueError, match="reads observation key 'approach', which this env does not give: declare"
    ):
        agent.predict({"depth_histogram": np.zeros((3, 5, 8), np.float32)})


def test_evaluate_scores_an_agent_written_outside_flownav(
    agent_file: Path, tmp_path: Path, monkeypatch
) -> None:
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "episodes.csv"
    command = ["evaluate", "--agent", "my_agent.py:make_agent", "--layouts", "1", "--out", str(out)]
    assert (
        main(
            [*command, "--tiers", "FlowNavSingle-v0", "--env", "camera_width=96", "--env", "camera_height=72"]
        )
        == 0
    )
    (row,) = read_records(out)
    assert row["agent"] == f"{agent_file}:make_agent"  # absolute, so workers elsewhere find it
    assert json.loads(row["env_kwargs"])["observe_nearness"] is True
    assert "source_sha256" in json.loads(row["agent_params"])


def test_evaluate_refuses_a_bad_agent_before_flying(tmp_path: Path, capsys) -> None:
    out = tmp_path / "episodes.csv"
    assert main(["evaluate", "--agent", "no_such_module_anywhere:make", "--out", str(out)]) == 2
    assert "cannot import the agent module" in capsys.readouterr().err
    assert not out.exists()
