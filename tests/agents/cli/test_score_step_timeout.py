"""An outside agent whose ``predict`` never returns: ``flownav score --step-timeout`` ends the run in one line
naming the agent, the episode and the limit, records nothing of that episode and leaves no claim behind."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from agents.analysis.records import read_records
from agents.cli import main
from agents.common.seeds import suite_seeds
from agents.evaluation.claims import claims_path
from agents.evaluation.suite import EPISODES_CSV

HANGING_AGENTS = (
    "import time\n\n\n"
    "class Sleeps:\n"
    "    def predict(self, observation, state=None, episode_start=None, deterministic=True):\n"
    "        time.sleep(10**6)\n\n\n"
    "class Spins:\n"
    "    def predict(self, observation, state=None, episode_start=None, deterministic=True):\n"
    "        while True:\n"
    "            pass\n\n\n"
    "def sleeps():\n    return Sleeps()\n\n\n"
    "def spins():\n    return Spins()\n"
)


def hanging_agent_file(folder: Path) -> Path:
    path = folder / "hangs.py"
    path.write_text(HANGING_AGENTS)
    return path


def score_args(agent: str, out: Path, *extra: str) -> list[str]:
    """``flownav score`` of ``agent`` on the first layout of the clean tier."""
    return ["score", "--agent", agent, "--tiers", "clean", "--layouts", "1", "--out", str(out), *extra]


def expected_line(agent: str, limit: str) -> str:
    return (
        f"flownav score: error: agent {agent} did not return from predict within {limit} s (--step-timeout) in "
        f"the episode on tier clean, layout seed {suite_seeds(1)[0]}; the run stopped and that episode is not "
        "recorded: fix the agent, or raise --step-timeout (0 = no limit)"
    )


def test_a_sleeping_predict_ends_the_run_in_one_line_recording_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    agent = f"{hanging_agent_file(tmp_path)}:sleeps"
    out = tmp_path / "out"
    started = time.monotonic()
    assert main(score_args(agent, out, "--workers", "1", "--step-timeout", "1")) == 2
    assert time.monotonic() - started < 60  # the limit, not the agent's million seconds
    assert capsys.readouterr().err.strip().splitlines()[-1] == expected_line(agent, "1")
    assert read_records(out / EPISODES_CSV) == []
    assert not claims_path(out / EPISODES_CSV).exists()  # a second run need not wait for the claim to expire


def test_a_spinning_predict_in_a_pool_worker_is_cut_off(tmp_path: Path) -> None:
    agent = f"{hanging_agent_file(tmp_path)}:spins"
    out = tmp_path / "out"
    # A process of its own, so a limit that failed would fail this test instead of hanging the suite.
    finished = subprocess.run(
        [
            sys.executable,
            "-c",
            "import sys; from agents.cli import main; sys.exit(main(sys.argv[1:]))",
            *score_args(agent, out, "--workers", "2", "--step-timeout", "0.5"),
        ],
        capture_output=True,
        text=True,
        timeout=180,
        env={**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")},
    )
    assert finished.returncode == 2
    assert finished.stderr.strip().splitlines()[-1] == expected_line(agent, "0.5")
    assert read_records(out / EPISODES_CSV) == []
    assert not claims_path(out / EPISODES_CSV).exists()


@pytest.mark.parametrize("limit", ["-1", "nan", "inf"])
def test_a_bad_step_timeout_is_one_line(
    limit: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    agent = f"{hanging_agent_file(tmp_path)}:sleeps"
    assert main(score_args(agent, tmp_path / "out", "--workers", "1", "--step-timeout", limit)) == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert error == [
        f"flownav score: error: --step-timeout must be a number of seconds >= 0 (0 = no limit), got {float(limit)!r}"
    ]
