"""Agents learned once per tier: where each tier's training seeds lie, and what the suite flies on each tier."""

from __future__ import annotations

from pathlib import Path

import pytest

from agents.evaluation.episode_tasks import EpisodeTask
from agents.evaluation.suite import agent_runs, suite_tasks
from agents.policies import load_agent, policy_file, policy_folder, trained_seeds
from agents.policies.learned import default_runs
from flownav_env.tiers import TIER_NAMES

STUDENT = "ppo_flow_camera_student_fine_rounds6"  # per_tier in configs/agents.yaml, shipped on hard


def _ship(folder: Path, *seeds: int) -> None:
    folder.mkdir(parents=True)
    for seed in seeds:
        (folder / f"seed_{seed}.zip").write_bytes(b"")


def test_each_tier_keeps_its_own_training_seeds(tmp_path: Path) -> None:
    _ship(tmp_path / f"{STUDENT}_hard", 0, 1)
    _ship(tmp_path / f"{STUDENT}_noisy", 1, 2)
    assert policy_folder(STUDENT, tmp_path, tier="hard") == tmp_path / f"{STUDENT}_hard"
    assert trained_seeds(STUDENT, tmp_path, tier="hard") == [0, 1]
    assert trained_seeds(STUDENT, tmp_path, tier="clean") == []
    assert trained_seeds(STUDENT, tmp_path) == [0, 1, 2]  # any tier's
    assert (
        policy_file(f"{STUDENT}@1", directory=tmp_path, tier="noisy")
        == tmp_path / f"{STUDENT}_noisy/seed_1.zip"
    )
    # Without a tier, the first tier in suite order that ships the seed stands for the others.
    assert policy_file(f"{STUDENT}@2", directory=tmp_path) == tmp_path / f"{STUDENT}_noisy/seed_2.zip"
    runs, message = default_runs(STUDENT, tmp_path)
    assert (
        runs == [f"{STUDENT}@0", f"{STUDENT}@1", f"{STUDENT}@2"]
        and f"{STUDENT}_<tier>/seed_<k>.zip" in message
    )


def test_a_tier_is_needed_exactly_where_an_agent_is_per_tier(tmp_path: Path) -> None:
    with pytest.raises(
        ValueError, match=f"{STUDENT} is learned once per tier: name one of clean, hard, noisy"
    ):
        policy_folder(STUDENT, tmp_path)
    with pytest.raises(ValueError, match="ppo_flow has one policy for every tier, got tier 'hard'"):
        policy_folder("ppo_flow", tmp_path, tier="hard")
    assert default_runs(STUDENT, tmp_path) == (
        [],
        f"{STUDENT}: no policy on any tier at {tmp_path / STUDENT}_<tier>/seed_<k>.zip",
    )


def test_a_per_tier_agent_named_alone_is_not_one_policy() -> None:
    with pytest.raises(
        ValueError, match=f"{STUDENT} is learned once per tier: flownav suite and score fly each"
    ):
        load_agent(STUDENT)


def test_the_suite_flies_each_tier_with_that_tiers_policies_and_skips_a_tier_not_shipped() -> None:
    runs = agent_runs(STUDENT)
    shipped = trained_seeds(STUDENT, tier="hard")
    unshipped = [name for name in TIER_NAMES if not trained_seeds(STUDENT, tier=name)]
    assert shipped
    tasks = suite_tasks({STUDENT: runs}, ["hard", *unshipped], layouts=2)
    assert {task.factor for task in tasks} == {"hard"} and len(tasks) == 2 * len(shipped)
    for task in tasks:
        assert task.policy is not None and Path(task.policy).parent.name == f"{STUDENT}_hard"
        assert task.env_id == "FlowNavHard-v1" and task.identity()["policy_sha256"]


def test_a_task_flies_the_policy_of_the_tier_whose_id_it_flies() -> None:
    task = EpisodeTask(f"{STUDENT}@0", "clean", 0.0, 0, env_id="FlowNavHard-v1")
    assert task.policy_path() == policy_file(f"{STUDENT}@0", tier="hard")
    assert task.policy_path() == policy_folder(STUDENT, tier="hard") / "seed_0.zip"
    with pytest.raises(
        ValueError,
        match=rf"{STUDENT}@0 is learned once per tier: fly it on a suite tier .*got 'FlowNavSingle-v0'",
    ):
        EpisodeTask(f"{STUDENT}@0", "clean", 0.0, 0, env_id="FlowNavSingle-v0").policy_path()
    named = EpisodeTask(
        f"{STUDENT}@0", "clean", 0.0, 0, env_id="FlowNavSingle-v0", policy="elsewhere/seed_0.zip"
    )
    assert named.policy_path() == Path("elsewhere/seed_0.zip")
