"""Episodes, their CSV, statistics and the runner, on the real env at small resolutions."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import yaml

import flownav_env  # noqa: F401
from agents.analysis.records import drop_agents, read_records
from agents.analysis.statistics import wilson_interval
from agents.common.seeds import TEST_SEED_START
from agents.evaluation.episode_tasks import EpisodeTask, pending_tasks
from agents.evaluation.runner import execute, run_task
from agents.policies import agent_env_kwargs

SMALL = {"camera_width": 96, "camera_height": 72}


def test_wilson_interval_matches_known_values() -> None:
    low, high = wilson_interval(5, 10)
    assert low == pytest.approx(0.2366, abs=1e-3) and high == pytest.approx(0.7634, abs=1e-3)
    assert wilson_interval(0, 10)[0] == 0.0
    assert wilson_interval(0, 0) == (0.0, 1.0)


def test_learned_agents_fly_with_the_env_settings_they_were_trained_with(tmp_path: Path) -> None:
    policy = tmp_path / "ppo_oracle.zip"
    policy.with_suffix(".yaml").write_text(
        yaml.safe_dump({"name": "ppo_oracle", "env": {"obs_source": "oracle", **SMALL}})
    )
    assert agent_env_kwargs("ppo_oracle", policy) == {"obs_source": "oracle", **SMALL}
    task = EpisodeTask(
        "ppo_oracle", "brightness", 0.5, 0, policy=str(policy), env_kwargs=(("brightness", 0.5),)
    )
    assert task.env_settings() == {"obs_source": "oracle", **SMALL, "brightness": 0.5}
    override = EpisodeTask(
        "ppo_oracle", "clean", 0.0, 0, policy=str(policy), env_kwargs=(("camera_width", 64),)
    )
    assert override.env_settings()["camera_width"] == 64  # the task's settings win
    assert agent_env_kwargs("bee") == {} and agent_env_kwargs("ppo_robust", tmp_path / "none.zip") == {}
    nested = (*SMALL.items(), ("estimator_kwargs", {"min_parallax_px": 2.0}))  # a dict inside the settings
    assert run_task(EpisodeTask("straight", "clean", 0.0, 0, "FlowNavSingle-v0", nested)).collision


def test_evaluation_resumes_after_interruption(tmp_path: Path) -> None:
    csv_path = tmp_path / "episodes.csv"
    env_kwargs = tuple(sorted(SMALL.items()))
    tasks = [
        EpisodeTask("straight", "clean", 0.0, TEST_SEED_START + i, "FlowNavSingle-v0", env_kwargs)
        for i in range(2)
    ]
    assert execute(tasks[:1], csv_path) == 1  # "interrupted" after the first episode
    with csv_path.open("a") as handle:
        handle.write("straight,clean,0.0,1000001,Tr")  # an episode torn mid-write is not counted
    assert [t.seed for t in pending_tasks(tasks, csv_path)] == [TEST_SEED_START + 1]
    assert execute(tasks, csv_path) == 1
    rows = read_records(csv_path)
    assert sorted(r["seed"] for r in rows) == [TEST_SEED_START, TEST_SEED_START + 1]
    assert all(r["collision"] for r in rows)


def test_drop_agents_deletes_only_their_rows_and_keeps_the_rest_byte_for_byte(tmp_path: Path) -> None:
    path = tmp_path / "episodes.csv"
    assert drop_agents(path, ["bee"]) == 0  # no file yet: nothing to delete
    tasks = [
        EpisodeTask(agent, "clean", 0.0, TEST_SEED_START, "FlowNavSingle-v0", tuple(SMALL.items()), None)
        for agent in ("straight", "bee")
    ]
    execute(tasks, path)
    header, straight_line, _ = path.read_text().splitlines(keepends=True)
    assert drop_agents(path, ["bee", "ppo_flow"]) == 1
    assert path.read_text() == header + straight_line
    assert not path.with_name(path.name + ".tmp").exists()


def test_video_writes_an_mp4(tmp_path: Path) -> None:
    import imageio.v2 as imageio

    from agents.studies.video import record_episode

    out = tmp_path / "bee.mp4"
    record_episode("bee", "FlowNavSingle-v0", TEST_SEED_START, out, max_steps=5)
    frames = [frame for frame in imageio.get_reader(out)]  # list() trips on the reader's infinite len()
    assert len(frames) == 5 and frames[0].shape == (240, 640, 3)


@pytest.mark.parametrize(
    ("command", "defaults"),
    [
        (
            "evaluate",
            ["(default: 20)", "(default: clean)", "(default: runs/evaluations/episodes.csv)"],
        ),
        (
            "sweep",
            [
                "(default: the repository's configs/sweep.yaml)",
                "(default: runs/sweep;",
                "(default: the config's)",
            ],
        ),
        ("demo", ["(default: 4)", "(default: 2)", "(default: runs/demo)"]),
    ],
)
def test_help_pages_show_their_defaults(capsys, command: str, defaults: list[str]) -> None:
    from agents.cli import main

    with pytest.raises(SystemExit):
        main([command, "--help"])
    page = " ".join(capsys.readouterr().out.split())  # argparse wraps lines
    for default in defaults:
        assert default in page


def test_demo_flies_every_suite_agent_over_all_its_runs_on_the_tier_s_first_frozen_layouts(
    tmp_path: Path, monkeypatch, capsys
) -> None:
    from agents.cli import main
    from agents.common.seeds import suite_seeds
    from agents.evaluation import suite
    from flownav_env.tiers import TIERS

    flown: list[EpisodeTask] = []
    monkeypatch.setattr(suite, "execute", lambda tasks, *args, **kwargs: flown.extend(tasks) or 0)
    monkeypatch.chdir(tmp_path)
    assert main(["demo", "--layouts", "3", "--tiers", "hard"]) == 0
    runs = {name for agent in suite.suite_agents() for name in suite.agent_runs(agent)}
    assert {task.agent for task in flown} == runs
    assert {task.seed for task in flown} == set(suite_seeds(3)) and len(flown) == 3 * len(runs)
    assert {task.env_id for task in flown} == {TIERS["hard"].env_id}
    # The suite's own page, written where the demo says.
    page = (tmp_path / "runs" / "demo" / "suite.md").read_text()
    assert page.startswith("# FlowNav suite v") and "Generated " in page
    out = capsys.readouterr().out
    assert "every agent on the first 3 frozen test layouts of the hard tier, ranked as the suite ranks" in out
    assert f"written to {Path('runs/demo/suite.md')}" in out


def test_demo_needs_two_layouts_to_rank(capsys) -> None:
    from agents.cli import main

    assert main(["demo", "--layouts", "1"]) == 2
    assert (
        "--layouts must be 2-300 (a ranking compares agents on at least 2), got 1" in capsys.readouterr().err
    )


def test_evaluate_flies_a_learned_agents_shipped_training_seeds_from_another_folder(
    tmp_path: Path, monkeypatch, capsys
) -> None:
    import hashlib

    from agents.cli import main
    from agents.common.locations import POLICIES_DIR
    from agents.policies import trained_seeds

    monkeypatch.chdir(tmp_path)
    args = ["evaluate", "--agent", "ppo_flow", "--layouts", "2", "--tiers", "FlowNavSingle-v0"]
    assert main([*args, "--env", "camera_width=96", "--env", "camera_height=72", "--out", "e.csv"]) == 0
    rows = read_records(tmp_path / "e.csv")
    # Not the single results/policies/ppo_flow.zip trained before the seeds: the seeds, one per layout.
    assert [(row["agent"], int(row["seed"])) for row in rows] == [
        ("ppo_flow@0", 1_000_000),
        ("ppo_flow@1", 1_000_001),
    ]
    for row in rows:
        shipped = POLICIES_DIR / "ppo_flow" / f"seed_{row['agent'][-1]}.zip"
        assert row["policy_sha256"] == hashlib.sha256(shipped.read_bytes()).hexdigest()
        assert row["env_kwargs"] == '{"camera_height":72,"camera_width":96,"obs_source":"flow"}'
    out = capsys.readouterr().out
    seeds = ", ".join(str(seed) for seed in trained_seeds("ppo_flow"))
    assert (
        len(trained_seeds("ppo_flow")) >= 2
        and f"ppo_flow: training seeds {seeds} in turn over the layouts" in out
    )
    assert re.search(r"^\| ppo_flow \| \S+ \| \S+ \| 2 \|", out, re.MULTILINE)  # seeds pooled in one row


def test_evaluate_flies_the_single_policy_only_when_asked(tmp_path: Path, monkeypatch) -> None:
    from agents.cli import main
    from agents.common.locations import RESULTS_DIR
    from agents.evaluation import runner

    flown: list[EpisodeTask] = []
    monkeypatch.setattr(runner, "execute", lambda tasks, *args, **kwargs: flown.extend(tasks) or 0)
    monkeypatch.chdir(tmp_path)
    single = str(RESULTS_DIR / "sweep_thesis_range" / "policies" / "ppo_flow.zip")  # the pre-seed policy
    assert main(["evaluate", "--agent", "ppo_flow", "--policy", single, "--layouts", "2"]) == 0
    assert [(task.agent, task.policy) for task in flown] == [("ppo_flow", single)] * 2


def test_evaluate_refuses_a_learned_agent_with_no_policy(tmp_path: Path, monkeypatch, capsys) -> None:
    from agents.cli import main
    from agents.policies import learned

    monkeypatch.setattr(learned, "POLICIES_DIR", tmp_path)  # a checkout with no policies
    monkeypatch.chdir(tmp_path)
    assert main(["evaluate", "--agent", "ppo_oracle", "--layouts", "1"]) == 2
    error = capsys.readouterr().err
    assert "flownav evaluate: error: nothing to fly for ppo_oracle: no policy at " in error
    assert "seed_<k>.zip or " in error and not (tmp_path / "results").exists()
