"""An outside agent runs in a process of its own: it cannot reach the env, and however its process ends (exit,
a signal, a memory or CPU-time limit) the run stops with one line naming the agent, the tier and the layout,
records nothing of that episode, hangs with no worker count, and leaves no process of the agent behind."""

from __future__ import annotations

import dataclasses
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from helpers import processes_with

from agents.analysis.records import read_records
from agents.cli import main
from agents.common.seeds import suite_seeds
from agents.evaluation.agent_settings import flown_settings
from agents.evaluation.episode_tasks import EpisodeTask, canonical_json, suite_task
from agents.evaluation.suite import EPISODES_CSV
from agents.policies import load_agent
from agents.policies.agent_process import check_plain_settings, end_agent_processes
from flownav_env.tiers import SUITE_VERSION, tier, tier_value

OBSERVATION = {"depth_histogram": np.zeros((3, 5, 6), np.float32), "state": np.zeros(7, np.float32)}
AGENT_TEMPLATE = """
import gc, os, signal, subprocess, sys, time
import numpy as np

class Agent:
    env_settings = {settings}

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
{body}
        return np.zeros(3, np.float32), state

def make_agent():
    return Agent()
"""
INDENT = " " * 8


def agent_file(folder: Path, body: str, settings: str = "{}", name: str = "stranger.py") -> str:
    path = folder / name
    lines = "\n".join(INDENT + line for line in body.strip().splitlines())
    path.write_text(AGENT_TEMPLATE.format(body=lines, settings=settings))
    return f"{path}:make_agent"


def score_args(agent: str, out: Path, *extra: str) -> list[str]:
    return ["score", "--agent", agent, "--tiers", "clean", "--layouts", "1", "--out", str(out), *extra]


def episode() -> str:
    return f"the episode on tier clean, layout seed {suite_seeds(1)[0]}"


def ended_line(agent: str, how: str) -> str:
    return (
        f"flownav score: error: agent {agent}'s process ended during predict in {episode()} ({how}); the run "
        "stopped and that episode is not recorded"
    )


def error_lines(err: str) -> list[str]:
    """What the command said on stderr besides its progress bar."""
    assert "Traceback" not in err, err
    return [line for line in err.strip().splitlines() if "episode/s]" not in line and line.strip()]


def score_in_a_process(argv: list[str]) -> subprocess.CompletedProcess[str]:
    """``flownav`` in a process of its own, so that a hang fails this test instead of hanging the suite."""
    return subprocess.run(
        [
            sys.executable,
            "-c",
            "import sys; from agents.cli import main; sys.exit(main(sys.argv[1:]))",
            *argv,
        ],
        capture_output=True,
        text=True,
        timeout=240,
        env={**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")},
    )


ENDINGS = {
    "sys.exit(0)": "it exited with status 0",
    "os._exit(3)": "it exited with status 3",
    "os.abort()": "killed by SIGABRT",
}


@pytest.mark.parametrize("ending", sorted(ENDINGS))
def test_an_agent_process_that_ends_stops_the_run_in_one_line(
    ending: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    agent = agent_file(tmp_path, ending)
    assert main(score_args(agent, tmp_path / "out", "--workers", "1")) == 2
    assert error_lines(capsys.readouterr().err) == [ended_line(agent, ENDINGS[ending])]
    assert read_records(tmp_path / "out" / EPISODES_CSV) == []


@pytest.mark.parametrize("ending", ["sys.exit(0)", "os._exit(3)"])
def test_an_agent_process_that_ends_under_two_workers_does_not_hang(ending: str, tmp_path: Path) -> None:
    agent = agent_file(tmp_path, ending)
    finished = score_in_a_process(score_args(agent, tmp_path / "out", "--workers", "2"))
    assert finished.returncode == 2
    assert error_lines(finished.stderr) == [ended_line(agent, ENDINGS[ending])]
    assert read_records(tmp_path / "out" / EPISODES_CSV) == []


def test_an_agent_that_searches_its_process_for_the_env_finds_none(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # The sandbox shows the agent none of the scorer's files: it reports what it found in its error line.
    search = """
if episode_start is not None and episode_start.any():
    kinds = {repr(type(o)) for o in gc.get_objects()}
    env_kinds = sorted(k for k in kinds if "FlowNavEnv" in k or "MjData" in k or "MjModel" in k)
    raise ValueError("FOUND " + repr((len(kinds), env_kinds)))
"""
    agent = agent_file(tmp_path, search)
    assert main(score_args(agent, tmp_path / "out", "--workers", "1")) == 2
    (line,) = error_lines(capsys.readouterr().err)
    kinds, env_kinds = eval(line.partition("FOUND ")[2].partition(" (at ")[0])  # from the test's own agent
    assert kinds > 100 and env_kinds == []  # it searched a live process, and found no env in it


def test_processes_an_agent_started_end_with_the_run(tmp_path: Path) -> None:
    marker = str(800000 + os.getpid() % 99999)
    body = f"""
if episode_start is not None and episode_start.any():
    subprocess.Popen(["sleep", "{marker}"])
"""
    agent = agent_file(tmp_path, body)
    assert main(score_args(agent, tmp_path / "out", "--workers", "1")) == 0
    deadline = time.monotonic() + 10
    while processes_with(f"sleep\0{marker}") and time.monotonic() < deadline:
        time.sleep(0.1)
    assert processes_with(f"sleep\0{marker}") == []


def test_an_agent_past_its_memory_limit_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    agent = agent_file(tmp_path, "hoard = bytearray(3 * 2**30)")
    assert main(score_args(agent, tmp_path / "out", "--workers", "1", "--agent-memory", "1.5")) == 2
    (line,) = error_lines(capsys.readouterr().err)
    assert line.startswith(f"flownav score: error: agent {agent}: predict ran out of memory (MemoryError")
    assert line.endswith(f"under its limit of 1.5 GiB (--agent-memory) in {episode()}")


def test_an_agent_past_its_cpu_time_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    agent = agent_file(tmp_path, "while True:\n    pass")
    argv = score_args(agent, tmp_path / "out", "--workers", "1", "--agent-cpu", "3", "--step-timeout", "0")
    assert main(argv) == 2
    assert error_lines(capsys.readouterr().err) == [
        ended_line(agent, "killed by SIGXCPU: it used its 3 s of CPU time (--agent-cpu)")
    ]


def test_a_nan_action_names_the_agent_the_episode_and_its_predict(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    agent = agent_file(tmp_path, "return np.array([np.nan, 0.0, 0.0]), state")
    assert main(score_args(agent, tmp_path / "out", "--workers", "1")) == 2
    assert error_lines(capsys.readouterr().err) == [
        f"flownav score: error: agent {agent} returned the action [nan, 0.0, 0.0] (its predict is at "
        f"{tmp_path / 'stranger.py'}:8) in {episode()}: an action must be finite numbers"
    ]


def test_a_setting_that_only_looks_like_a_float_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    lying = "class Lying(float):\n    def __ne__(self, other):\n        return False\n\n"
    agent = agent_file(tmp_path, "pass", settings="{'obstacle_density': Lying(0.0)}")
    path = Path(agent.rpartition(":")[0])
    path.write_text(lying + path.read_text())
    assert main(score_args(agent, tmp_path / "out", "--workers", "1")) == 2
    assert error_lines(capsys.readouterr().err) == [
        f"flownav score: error: agent {agent}: env_settings['obstacle_density'] is a Lying, not a plain bool, "
        "int, float or str, nor a list of numbers"
    ]


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        ({"obstacle_density": np.float64(0.0)}, "env_settings['obstacle_density'] is a float64, not a plain"),
        ({"observe_approach": [True]}, "env_settings['observe_approach'] is a list, not a plain"),
        ({1: True}, "env_settings must map env setting names to values, got {1: True}"),
    ],
)
def test_settings_must_be_plain_values(settings: dict, message: str) -> None:
    with pytest.raises(ValueError, match=f"^agent a.py:make: {re.escape(message)}"):
        check_plain_settings("a.py:make", settings)


def test_settings_may_be_lists_of_numbers_as_the_histogram_resolution_is() -> None:
    asked = {"histogram_sectors": [3, 15], "depth_bin_edges": [0.5, 1.0, 2.0]}
    assert check_plain_settings("a.py:make", asked) == {
        "histogram_sectors": (3, 15),
        "depth_bin_edges": (0.5, 1.0, 2.0),
    }


def test_an_outside_agent_may_ask_for_a_finer_histogram(tmp_path: Path) -> None:
    settings = "{'histogram_sectors': [3, 15], 'depth_bin_edges': [0.5, 1.0, 1.5, 2.0, 3.0, 4.0]}"
    spec = agent_file(tmp_path, "pass", settings=settings)
    flown = flown_settings(_clean_task(spec), load_agent(spec))
    assert flown["histogram_sectors"] == (3, 15) and flown["depth_bin_edges"] == (
        0.5,
        1.0,
        1.5,
        2.0,
        3.0,
        4.0,
    )


def test_an_action_of_the_wrong_shape_names_the_agents_own_file_and_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    agent = agent_file(tmp_path, "return np.zeros(5), state")
    assert main(score_args(agent, tmp_path / "out", "--workers", "1")) == 2
    (line,) = error_lines(capsys.readouterr().err)
    assert line.endswith(
        f"step 1: action must have shape (3,), got shape (5,); the action came from predict at "
        f"{tmp_path / 'stranger.py'}:8"
    )


def test_the_agent_keeps_its_state_in_its_process_and_a_closed_one_starts_again(tmp_path: Path) -> None:
    counting = """
state = 0 if state is None else state + 1
return np.array([float(state), 0.0, 0.0]), state
"""
    agent = load_agent(agent_file(tmp_path, counting))
    first = [agent.predict(OBSERVATION, None, np.array([i == 0]))[0][0] for i in range(3)]
    assert first == [0.0, 1.0, 2.0]
    end_agent_processes()
    assert agent.predict(OBSERVATION, None, np.array([True]))[0][0] == 0.0


def _clean_task(spec: str, **changes: object) -> EpisodeTask:
    clean = tier("clean")
    task = suite_task(
        spec,
        "clean",
        suite_seeds(1)[0],
        env_id=clean.env_id,
        settings=clean.settings,
        suite_version=SUITE_VERSION,
    )
    return dataclasses.replace(task, **changes)


def test_settings_other_than_those_planned_are_refused_where_the_episode_flies(tmp_path: Path) -> None:
    spec = agent_file(tmp_path, "pass")
    task = _clean_task(spec, planned_settings='{"observe_approach":true}')
    flown = canonical_json(dict(tier("clean").settings))
    with pytest.raises(ValueError) as raised:
        flown_settings(task, load_agent(spec))
    assert str(raised.value) == (
        f"agent {spec} declares env settings {flown} in the process that flies {episode()}, but "
        '{"observe_approach":true} where the run was planned: an agent\'s env_settings must be the same in every '
        "process; nothing was recorded of that episode"
    )


def test_a_tier_setting_is_refused_where_the_episode_flies(tmp_path: Path) -> None:
    spec = agent_file(tmp_path, "pass", settings="{'obstacle_density': 0.0}")
    fixed = tier_value("clean", "obstacle_density")
    with pytest.raises(
        ValueError,
        match=rf"^agent {re.escape(spec)} asks for obstacle_density=0.0, but tier clean fixes obstacle_density={fixed!r}",
    ):
        flown_settings(_clean_task(spec), load_agent(spec))
