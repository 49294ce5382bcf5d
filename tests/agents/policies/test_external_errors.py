"""What goes wrong in an outside agent's own code is said in one line naming the agent and the line of its file,
at the Python API and at the command line (exit status 2, no traceback), also from a process pool."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from agents.cli import main
from agents.common.seeds import suite_seeds
from agents.evaluation.progress import PROGRESS_PREFIX
from agents.policies import load_agent
from agents.policies.external import display_name

OBSERVATION = {"depth_histogram": np.zeros((3, 5, 6), np.float32), "state": np.zeros(7, np.float32)}

RAISING_IN_PREDICT = """
class Agent:
    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        return self.steer(observation)

    def steer(self, observation):
        raise RuntimeError("no gap found")

def make_agent():
    return Agent()
"""

BARE_ACTION = """
import numpy as np

class Agent:
    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        return np.zeros(3, np.float32)

def make_agent():
    return Agent()
"""


def write_agent(folder: Path, source: str, name: str = "my_agent.py") -> str:
    path = folder / name
    path.write_text(source)
    return f"{path}:make_agent"


def one_error_line(capsys: pytest.CaptureFixture[str], command: str) -> str:
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err, err
    # Besides the progress lines (on stderr), the one line the command line prints.
    lines = [line for line in err.splitlines() if not line.startswith(PROGRESS_PREFIX)]
    assert len(lines) == 1 and lines[0].startswith(f"flownav {command}: error: "), err
    return lines[0]


def test_a_file_with_a_syntax_error_is_one_line_with_its_line(tmp_path: Path) -> None:
    spec = write_agent(tmp_path, "x = 1\ndef make_agent(:\n    pass\n", "broken_syntax.py")
    with pytest.raises(
        ValueError, match=r"broken_syntax\.py does not import: SyntaxError: .* \(at .*broken_syntax\.py:2\)$"
    ):
        load_agent(spec)


def test_a_file_whose_import_fails_names_the_missing_module_and_line(tmp_path: Path) -> None:
    spec = write_agent(tmp_path, "import numpy\nimport flownav_no_such_module\n", "failing_import.py")
    with pytest.raises(
        ValueError,
        match=r"failing_import\.py does not import: ModuleNotFoundError: No module named 'flownav_no_such_module' "
        r"\(at .*failing_import\.py:2\)$",
    ):
        load_agent(spec)


def test_a_module_that_raises_on_import_is_one_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "raising_module_agent.py").write_text("raise KeyError('weights')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(
        ValueError, match=r"cannot import the agent module 'raising_module_agent' \(KeyError: 'weights'"
    ):
        load_agent("raising_module_agent:make_agent")


def test_a_factory_that_raises_names_the_factory_and_its_line(tmp_path: Path) -> None:
    spec = write_agent(tmp_path, "def make_agent():\n    return 1 / 0\n", "dividing.py")
    with pytest.raises(
        ValueError,
        match=r"calling make_agent raised ZeroDivisionError: division by zero \(at .*dividing\.py:2\)",
    ):
        load_agent(spec)


def test_predict_that_raises_names_the_agent_and_the_line_in_its_file(tmp_path: Path) -> None:
    spec = write_agent(tmp_path, RAISING_IN_PREDICT)
    with pytest.raises(
        ValueError, match=r"predict raised RuntimeError: no gap found \(at .*my_agent\.py:7\)$"
    ) as raised:
        load_agent(spec).predict(OBSERVATION)
    assert spec in str(raised.value) and "\n" not in str(raised.value)


def test_predict_returning_the_bare_action_says_what_it_must_return_and_where_predict_is(
    tmp_path: Path,
) -> None:
    with pytest.raises(
        ValueError,
        match=r"predict \(at .*my_agent\.py:5\) must return \(action, state\).* got an ndarray of shape \(3,\)",
    ):
        load_agent(write_agent(tmp_path, BARE_ACTION)).predict(OBSERVATION)


def test_a_missing_observation_key_keeps_its_own_message(tmp_path: Path) -> None:
    source = BARE_ACTION.replace("return np.zeros(3, np.float32)", "return observation['approach'], state")
    with pytest.raises(ValueError, match=r"^the agent reads observation key 'approach'.*observe_approach"):
        load_agent(write_agent(tmp_path, source)).predict(OBSERVATION)


@pytest.mark.parametrize(
    ("agent", "shown"),
    [
        ("/home/me/agents/my_agent.py:make_agent", "my_agent:make_agent"),
        ("my_pkg.my_module:make_agent", "my_pkg.my_module:make_agent"),
        ("sac:/home/me/models/model.zip", "sac:model"),
        ("bee_ttc", "bee_ttc"),
        ("ppo_flow@3", "ppo_flow@3"),
    ],
)
def test_display_names_are_short(agent: str, shown: str) -> None:
    assert display_name(agent) == shown


@pytest.mark.parametrize("workers", ["1", "2"])
def test_score_with_a_raising_predict_exits_2_with_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], workers: str
) -> None:
    spec = write_agent(tmp_path, RAISING_IN_PREDICT)
    command = ["score", "--agent", spec, "--tiers", "clean", "--layouts", "1", "--workers", workers]
    assert main([*command, "--out", str(tmp_path / "out")]) == 2
    line = one_error_line(capsys, "score")
    assert "predict raised RuntimeError: no gap found" in line and "my_agent.py:7" in line


def test_score_of_a_file_with_a_syntax_error_exits_2_before_flying(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = write_agent(tmp_path, "def make_agent(:\n", "broken_syntax.py")
    assert (
        main(["score", "--agent", spec, "--tiers", "clean", "--layouts", "1", "--out", str(tmp_path / "out")])
        == 2
    )
    assert "does not import: SyntaxError" in one_error_line(capsys, "score")
    assert not (tmp_path / "out").exists()


def test_score_of_an_agent_returning_the_bare_action_exits_2_with_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = write_agent(tmp_path, BARE_ACTION)
    command = ["score", "--agent", spec, "--tiers", "clean", "--layouts", "1", "--workers", "1"]
    assert main([*command, "--out", str(tmp_path / "out")]) == 2
    line = one_error_line(capsys, "score")
    assert f"predict (at {tmp_path / 'my_agent.py'}:5) must return (action, state)" in line


NAN_ACTION = BARE_ACTION.replace(
    "return np.zeros(3, np.float32)", "return np.full(3, np.nan, np.float32), state"
)


def test_score_of_an_agent_returning_a_nan_action_names_the_agent_tier_layout_and_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = write_agent(tmp_path, NAN_ACTION)
    command = ["score", "--agent", spec, "--tiers", "hard", "--layouts", "1", "--workers", "1"]
    assert main([*command, "--out", str(tmp_path / "out")]) == 2
    line = one_error_line(capsys, "score")
    assert spec in line and f"{tmp_path / 'my_agent.py'}:5" in line
    assert f"tier hard, layout seed {suite_seeds(1)[0]}" in line and "finite" in line


class NanAgent:
    """An agent in this process whose action is NaN."""

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        return np.full(3, np.nan, np.float32), state


def test_a_nan_action_in_process_names_the_agent_env_layout_step_and_predict_s_line() -> None:
    import gymnasium as gym

    from agents.evaluation.episode import run_episode

    env = gym.make("FlowNavSingle-v0", camera_width=64, camera_height=48)
    try:
        with pytest.raises(ValueError) as raised:
            run_episode(env, NanAgent(), 5, label="nan_agent", factor="clean")
    finally:
        env.close()
    line = NanAgent.predict.__code__.co_firstlineno
    assert str(raised.value).startswith(
        "agent 'nan_agent' on FlowNavSingle-v0 (clean), layout 5, step 1: action must"
    )
    assert str(raised.value).endswith(f"; the action came from predict at {Path(__file__)}:{line}")
