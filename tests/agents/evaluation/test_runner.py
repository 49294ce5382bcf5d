"""The runner: resume only into episodes of the same settings, Ctrl-C keeps what was flown, time limits."""

from __future__ import annotations

import hashlib
import multiprocessing
from dataclasses import replace
from pathlib import Path

import pytest
from helpers import with_other_defaults

import flownav_env  # noqa: F401
from agents.analysis.csv_file import LEGACY_FIELDS
from agents.analysis.records import OVERWRITE_HINT, append_record, read_episodes, read_records
from agents.common.locations import POLICIES_DIR
from agents.common.seeds import TEST_SEED_START
from agents.evaluation import runner
from agents.evaluation.episode import EpisodeRecord
from agents.evaluation.episode_tasks import EpisodeTask, pending_tasks
from agents.evaluation.runner import EpisodesInterrupted, execute
from flownav_env.limits import episode_step_limit

SMALL = (("camera_height", 72), ("camera_width", 96))
TASK = EpisodeTask("straight", "clean", 0.0, TEST_SEED_START, "FlowNavSingle-v0", SMALL)


def fake_record(task: EpisodeTask) -> EpisodeRecord:
    """A record as :func:`runner.run_task` stamps it, without flying."""
    numbers = dict.fromkeys(("progress_m", "time_s", "min_clearance_m", "path_length_m"), 1.0)
    return EpisodeRecord(
        task.agent, task.factor, task.level, task.seed, True, False, False, False,
        steps=10, mean_points_valid=1.0, median_depth_error=0.1, episode_return=-1.0, **numbers,
        **task.identity(), code_version="test",
    )  # fmt: skip


def test_records_carry_the_full_settings_they_were_flown_with(tmp_path: Path) -> None:
    record = runner.run_task(TASK)
    assert record.env_id == "FlowNavSingle-v0"
    assert record.env_kwargs == '{"camera_height":72,"camera_width":96}'
    # Every parameter of a reactive agent, its defaults too, so a re-tuned default is a different episode.
    assert record.agent_params == '{"flight_height":1.0,"heading_gain":1.5,"height_gain":2.0}'
    assert record.policy_sha256 == "" and record.code_version
    identity = EpisodeTask("ppo_flow@0", "clean", 0.0, 0).identity()
    assert identity["env_kwargs"] == '{"obs_source":"flow"}'  # the policy's training settings are included
    shipped = POLICIES_DIR / "ppo_flow" / "seed_0.zip"
    assert identity["policy_sha256"] == hashlib.sha256(shipped.read_bytes()).hexdigest()


@pytest.mark.parametrize(
    ("changed", "difference"),
    [
        (replace(TASK, env_id="FlowNavThree-v0"), "env_id 'FlowNavSingle-v0' there, 'FlowNavThree-v0' now"),
        (replace(TASK, env_kwargs=(*SMALL, ("brightness", 0.5))), 'env_kwargs \'{"camera_height"'),
        (replace(TASK, agent="bee", bee_params=(("yaw_gain", 1.0),)), None),  # another agent: another key
        (replace(TASK, env_kwargs=SMALL[:1]), "env_kwargs"),
    ],
)
def test_resume_refuses_a_csv_of_the_same_episodes_flown_with_other_settings(
    tmp_path: Path, changed: EpisodeTask, difference: str | None
) -> None:
    path = tmp_path / "episodes.csv"
    append_record(path, fake_record(TASK))
    assert pending_tasks([TASK], path) == []  # same settings: done
    if difference is None:
        assert pending_tasks([changed], path) == [changed]
        return
    with pytest.raises(ValueError) as error:
        pending_tasks([changed], path, OVERWRITE_HINT)
    message = str(error.value)
    assert message.startswith(
        f"{path} already holds episode (straight, clean, level 0, seed {TEST_SEED_START})"
    )
    assert difference in message and "--out" in message and "--overwrite" in message


def test_a_reactive_agents_new_defaults_are_not_its_old_episodes(tmp_path: Path, monkeypatch) -> None:
    from agents.policies.reactive import BeeAgent

    path = tmp_path / "episodes.csv"
    bee = EpisodeTask("bee", "clean", 0.0, 0)
    append_record(path, fake_record(bee))
    assert pending_tasks([bee], path) == []
    monkeypatch.setattr(BeeAgent, "__init__", with_other_defaults(BeeAgent.__init__, yaw_gain=0.123))
    with pytest.raises(ValueError, match=r"agent_params .*there, .*\"yaw_gain\":0.123\}' now"):
        pending_tasks([bee], path)


def test_bee_gains_and_policy_content_are_part_of_an_episode(tmp_path: Path) -> None:
    path = tmp_path / "episodes.csv"
    bee = EpisodeTask("bee", "candidate", 0.0, 0, bee_params=(("yaw_gain", 0.5),))
    append_record(path, fake_record(bee))
    with pytest.raises(
        ValueError, match=r"agent_params '.*\"yaw_gain\":0.5\}' there, '.*\"yaw_gain\":0.7\}' now"
    ):
        pending_tasks([replace(bee, bee_params=(("yaw_gain", 0.7),))], path)
    policy = tmp_path / "ppo_flow.zip"
    policy.write_bytes(b"first training")
    learned = EpisodeTask("ppo_flow", "clean", 0.0, 0, policy=str(policy))
    append_record(path, fake_record(learned))
    assert pending_tasks([learned], path) == []
    policy.write_bytes(b"retrained")
    with pytest.raises(
        ValueError, match=r"the policy file changed since these episodes were flown: policy_sha256"
    ):
        pending_tasks([learned], path)


def test_resuming_into_a_csv_from_before_identities_is_refused_but_it_still_reads(tmp_path: Path) -> None:
    path = tmp_path / "old.csv"
    path.write_text(
        ",".join(LEGACY_FIELDS) + "\r\n"
        "straight,clean,0.0,1000000,True,False,False,False,3.8,3.9,39,0.19,3.7,127.9,0.04,-6.1\r\n"
    )
    assert len(read_records(path)) == 1
    with pytest.raises(
        ValueError, match=r"old.csv predates episode identities .* --report-only.*rename the file"
    ):
        execute([TASK], path)


def test_the_evaluate_command_refuses_other_settings_and_overwrite_starts_a_new_file(
    tmp_path: Path, capsys
) -> None:
    from agents.cli import main

    out = tmp_path / "e.csv"
    args = [
        "evaluate",
        "--agent",
        "straight",
        "--layouts",
        "1",
        "--env",
        "camera_width=96",
        "--env",
        "camera_height=72",
    ]
    assert main([*args, "--tiers", "FlowNavSingle-v0", "--out", str(out)]) == 0
    assert f"flew 1 episodes into {out}" in capsys.readouterr().out
    assert main([*args, "--tiers", "FlowNavSingle-v0", "--out", str(out)]) == 0
    assert f"flew 0 episodes, 1 already in {out} (skipped)" in capsys.readouterr().out
    first = out.read_bytes()
    assert main([*args, "--tiers", "FlowNavThree-v0", "--out", str(out)]) == 2  # was: exit 0, old numbers
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1 and "flown with other settings (env_id 'FlowNavSingle-v0' there" in error[0]
    assert out.read_bytes() == first
    assert main([*args, "--tiers", "FlowNavThree-v0", "--out", str(out), "--overwrite"]) == 0
    (backup,) = tmp_path.glob("e.csv.bak-*")
    assert backup.read_bytes() == first
    assert [r["env_id"] for r in read_records(out)] == ["FlowNavThree-v0"]


def test_ctrl_c_keeps_the_flown_episodes_and_says_how_to_resume(tmp_path: Path, monkeypatch, capsys) -> None:
    path = tmp_path / "episodes.csv"
    tasks = [replace(TASK, seed=TEST_SEED_START + i) for i in range(3)]
    calls = []

    def fly_once_then_ctrl_c(task: EpisodeTask) -> EpisodeRecord:
        calls.append(task)
        if len(calls) > 1:
            raise KeyboardInterrupt
        return fake_record(task)

    monkeypatch.setattr(runner, "run_task", fly_once_then_ctrl_c)
    with pytest.raises(EpisodesInterrupted) as interrupted:
        execute(tasks, path)
    assert isinstance(interrupted.value, KeyboardInterrupt)
    assert str(interrupted.value) == (
        f"1 episodes are in {path} (1 of 3 flown in this run); run the same command again to resume"
    )
    assert interrupted.value.__suppress_context__  # no chained traceback
    assert [r["seed"] for r in read_records(path)] == [TEST_SEED_START]

    from agents.cli import main

    calls.clear()
    args = ["evaluate", "--agent", "straight", "--layouts", "3", "--tiers", "FlowNavSingle-v0"]
    args += ["--env", "camera_height=72", "--env", "camera_width=96", "--out", str(path)]
    assert main(args) == 130
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert error.startswith(f"flownav evaluate: interrupted: 2 episodes are in {path}")


def test_ctrl_c_stops_the_worker_pool(tmp_path: Path, monkeypatch) -> None:
    path = tmp_path / "episodes.csv"
    tasks = [replace(TASK, seed=TEST_SEED_START + i) for i in range(4)]
    real_append = runner.append_record

    def append_then_ctrl_c(csv_path: Path, record: EpisodeRecord) -> None:
        real_append(csv_path, record)
        raise KeyboardInterrupt

    monkeypatch.setattr(runner, "append_record", append_then_ctrl_c)
    with pytest.raises(EpisodesInterrupted, match="1 episodes are in"):
        execute(tasks, path, workers=2)
    assert multiprocessing.active_children() == []
    assert read_episodes(path).skipped == 0 and len(read_records(path)) == 1


def test_sigterm_stops_a_pooled_run_like_ctrl_c_with_one_message_and_no_worker_tracebacks(
    tmp_path: Path,
) -> None:
    # A scheduler or the end of a session stops a sweep with SIGTERM; its pool workers used to outlive the
    # parent and each print a BrokenPipeError traceback.
    import os
    import signal
    import subprocess
    import sys
    import time

    path = tmp_path / "episodes.csv"
    command = [
        sys.executable,
        "-c",
        "import sys; from agents.cli import main; sys.exit(main(sys.argv[1:]))",
        "evaluate",
        "--agent",
        "straight",
        "--layouts",
        "40",
    ]
    command += ["--tiers", "FlowNavSingle-v0", "--env", "camera_height=48", "--env", "camera_width=64"]
    command += ["--workers", "2", "--out", str(path)]
    process = subprocess.Popen(
        command,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "MUJOCO_GL": "egl"},
    )
    deadline = time.monotonic() + 120
    while not (path.is_file() and len(read_records(path)) >= 2):
        assert process.poll() is None and time.monotonic() < deadline, process.communicate()[1][-2000:]
        time.sleep(0.2)
    process.send_signal(signal.SIGTERM)
    _, error = process.communicate(timeout=60)
    assert process.returncode == 130, error[-2000:]
    assert "Traceback" not in error and "BrokenPipeError" not in error
    last = error.strip().splitlines()[-1]
    flown = len(read_records(path))
    assert last.startswith(f"flownav evaluate: interrupted: {flown} episodes are in {path}")
    assert 2 <= flown < 40 and read_episodes(path).skipped == 0


def test_alternating_agents_share_one_env_and_fly_as_if_each_had_its_own() -> None:
    # <agent>@all alternates training seeds from one layout to the next: the env must not be rebuilt for each.
    tasks = [
        replace(TASK, agent=agent, seed=TEST_SEED_START + i)
        for i, agent in enumerate(["straight", "bee"] * 2)
    ]
    cache = runner.FlightCache()
    shared = [runner.run_task(task, cache) for task in tasks]
    assert len(cache.envs) == 1 and len(cache.agents) == 2
    alone = []
    for task in tasks:
        own = runner.FlightCache()
        alone.append(runner.run_task(task, own))
        own.clear()
    assert shared == alone
    cache.clear()


def test_the_time_limit_follows_speed_frame_rate_and_field_length() -> None:
    assert episode_step_limit("FlowNav-v0", {}) is None  # the registered 400 steps
    assert episode_step_limit("FlowNav-v0", {"frame_rate": 50.0}) == 2000  # was 400: 8 s for 20 m
    assert episode_step_limit("FlowNav-v0", {"forward_speed": 0.5}) == 800
    assert episode_step_limit("FlowNav-v0", {"forward_speed": 0.5, "frame_rate": 20.0}) == 1600
    assert episode_step_limit("FlowNav-v0", {"field_length": 40.0}) == 800
    assert episode_step_limit("FlowNav-v0", {"frame_rate": 5.0}) == 400  # never below the registered limit
    assert episode_step_limit("FlowNav-v0", {"forward_speed": 2.0}) == 400
