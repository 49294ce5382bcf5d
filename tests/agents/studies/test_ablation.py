"""Ablations: every trained seed of each config flies the same validation layouts into its own CSV; missing
seeds are listed, not flown; the episode budget never reaches the test layouts."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from helpers import tiny_train_config

from agents.analysis.records import read_records
from agents.cli import main
from agents.common.seeds import (
    ABLATION_SEED_START,
    CAMERA_STUDENT_CONFIRM_SEED_START,
    CAMERA_STUDENT_RECIPE_SEED_START,
    STUDENT_RECIPE_SEED_START,
    TEST_SEED_START,
    TIER_VALIDATION_SEEDS,
    VALIDATION_SEED_START,
)
from agents.evaluation.trained_runs import seed_files
from agents.policies import REACTIVE_AGENTS
from agents.studies.ablation import ablation_tasks, compare_configs, tier_layouts
from agents.training.multiseed import seed_jobs, train_seeds
from agents.training.outputs import RunFiles


def test_ablation_layouts_are_validation_layouts() -> None:
    tasks = ablation_tasks(Path("p.zip"), 3)
    assert [t.seed for t in tasks] == [ABLATION_SEED_START + i for i in range(3)]
    assert VALIDATION_SEED_START <= ABLATION_SEED_START and tasks[-1].seed < TEST_SEED_START
    with pytest.raises(
        ValueError,
        match=r"--layouts must be in \[1, 100000\] \(validation layouts from 900,000\), got 100001",
    ):
        ablation_tasks(Path("p.zip"), 100_001)


def test_a_tier_flies_its_own_env_on_its_validation_layouts(tmp_path: Path) -> None:
    tasks = ablation_tasks(Path("p.zip"), 2, env_id="FlowNavHard-v0", first_layout=STUDENT_RECIPE_SEED_START)
    assert {t.env_id for t in tasks} == {"FlowNavHard-v0"}
    assert [t.seed for t in tasks] == [STUDENT_RECIPE_SEED_START, STUDENT_RECIPE_SEED_START + 1]
    assert tasks[-1].seed in TIER_VALIDATION_SEEDS
    out = tmp_path / "hard"
    lines = compare_configs(
        [], [0], out, episodes=1, workers=1, reference_agents=["straight"], tier="hard", suite_version="1"
    )
    row = read_records(out / "reference" / "straight.csv")[0]
    assert row["env_id"] == "FlowNavHard-v0" and row["seed"] == STUDENT_RECIPE_SEED_START
    assert (
        f"validation layouts {STUDENT_RECIPE_SEED_START:,}–{STUDENT_RECIPE_SEED_START:,} (tier `hard`, FlowNavHard-v0)"
        in "\n".join(lines)
    )


def test_a_v2_tier_reads_a_per_tier_recipes_runs_on_the_camera_student_layouts(tmp_path: Path) -> None:
    recipe = tmp_path / "student.yaml"
    recipe.write_text("name: student\nenv_id: FlowNav-v1\nper_tier: true\ntotal_timesteps: 64\n")
    out = tmp_path / "hard"
    lines = "\n".join(
        compare_configs(
            [recipe],
            [0],
            out,
            runs_dir=tmp_path / "runs",
            policies_dir=None,
            episodes=1,
            workers=1,
            reference_agents=["straight"],
            tier="hard",
            suite_version="2",
        )
    )
    row = read_records(out / "reference" / "straight.csv")[0]
    assert row["env_id"] == "FlowNavHard-v1" and row["seed"] == CAMERA_STUDENT_RECIPE_SEED_START
    assert CAMERA_STUDENT_RECIPE_SEED_START in TIER_VALIDATION_SEEDS
    # The hard tier's runs of the recipe, not yet trained: listed missing.
    assert "student_hard seed 0" in lines
    untiered = compare_configs([recipe], [0], tmp_path / "any", episodes=1, workers=1, report_only=True)
    assert "student (a recipe for every tier: compare it with --tiers)" in "\n".join(untiered)


@pytest.mark.parametrize(
    ("tier", "env", "message"),
    [
        ("steep", {}, r"^tier must be one of clean, hard, noisy, hard_noisy, got 'steep'$"),
        ("hard", {"obstacle_density": 0.2}, r"^--env and --tiers hard: a tier fixes its own settings"),
    ],
)
def test_a_bad_tier_or_a_tier_with_env_settings_is_refused(tmp_path: Path, tier, env, message) -> None:
    with pytest.raises(ValueError, match=message):
        compare_configs([], [0], tmp_path / "out", episodes=1, workers=1, env=env, tier=tier)


def test_each_trained_seed_flies_the_same_layouts_and_missing_ones_are_listed(tmp_path: Path) -> None:
    config, config_path = tiny_train_config(tmp_path, total=64, name="lever")
    runs_dir = tmp_path / "runs"
    train_seeds(seed_jobs(config, [0, 2], config_path=config_path, runs_dir=runs_dir, ship_to=None))
    out = tmp_path / "ablation"
    lines = compare_configs([config_path], [0, 1, 2], out, runs_dir=runs_dir, episodes=2, workers=1)
    text = "\n".join(lines)
    assert "| lever | 2 | 4 |" in text and "Not flown (not trained, or cut short): lever seed 1." in text
    # How the runs were trained, from each seed's record: the command and the minutes per seed.
    # Called from code, each seed's record names its own config file.
    trained_by = re.search(
        r"^- lever: (`[^`]*`(?:; )?)+ \(seed 0: [\d.]+ min, seed 2: [\d.]+ min\)$", text, re.M
    )
    assert trained_by is not None
    commands = re.findall(r"`(flownav train [^`]*)`", trained_by.group(0))
    assert len(commands) == 2
    for command, seed in zip(commands, (0, 2), strict=True):
        assert command.startswith(
            f"flownav train --config {runs_dir / 'lever' / f'seed_{seed}' / f'seed_{seed}.yaml'}"
        )
    for seed in (0, 2):
        rows = read_records(out / "lever" / f"seed_{seed}.csv")
        assert sorted(r["seed"] for r in rows) == [ABLATION_SEED_START, ABLATION_SEED_START + 1]
    assert (out / "ablation.md").read_text() == "\n".join(lines) + "\n"
    # Reporting again flies nothing and says the same.
    again = compare_configs([config_path], [0, 1, 2], out, runs_dir=runs_dir, episodes=2, report_only=True)
    assert again[4:] == lines[4:]
    # The same runs judged as seeds of a longer config: cut short, so not flown, and the report says so.
    (tmp_path / "longer").mkdir()
    _, longer = tiny_train_config(tmp_path / "longer", total=640, name="lever")
    cut = "\n".join(
        compare_configs([longer], [0], tmp_path / "cut", runs_dir=runs_dir, episodes=2, workers=1)
    )
    trained = RunFiles.of_seed(runs_dir, "lever", 0).trained_steps()
    assert (
        f"lever seed 0 (unfinished: {trained:,} of 640 steps)" in cut
        and not (tmp_path / "cut" / "lever").exists()
    )


def test_a_seed_whose_run_folder_is_gone_flies_its_shipped_policy(tmp_path: Path) -> None:
    import shutil

    config, config_path = tiny_train_config(tmp_path, total=64, name="lever")
    runs_dir, policies = tmp_path / "runs", tmp_path / "policies"
    train_seeds(seed_jobs(config, [0], config_path=config_path, runs_dir=runs_dir, ship_to=policies))
    # While the run folder holds the policy it shipped, the shipped copy (vouched for by its manifest) flies.
    steps = config.total_timesteps
    assert seed_files(runs_dir, policies, "lever", 0, steps).policy == policies / "lever" / "seed_0.zip"
    run_policy = runs_dir / "lever" / "seed_0" / "seed_0.zip"
    run_policy.write_bytes(run_policy.read_bytes() + b"\0")  # as if it trained on after shipping
    assert seed_files(runs_dir, policies, "lever", 0, steps).policy == run_policy
    # A run stopped short never counts: with more steps asked of it, the shipped policy flies, or nothing.
    assert seed_files(runs_dir, policies, "lever", 0, 10 * steps).policy == policies / "lever" / "seed_0.zip"
    assert seed_files(runs_dir, None, "lever", 0, 10 * steps) is None
    shutil.rmtree(runs_dir)  # a new checkout: runs/ is not committed, the shipped policy is
    out = tmp_path / "ablation"
    lines = compare_configs(
        [config_path], [0, 1], out, runs_dir=runs_dir, policies_dir=policies, episodes=2, workers=1
    )
    text = "\n".join(lines)
    assert "| lever | 1 | 2 |" in text and "lever seed 1." in text
    assert len(read_records(out / "lever" / "seed_0.csv")) == 2
    assert (out / "ablation_curves.png").is_file()  # drawn from the shipped evaluations
    # Without a policies folder only run folders count.
    nothing = compare_configs(
        [config_path], [0], tmp_path / "none", runs_dir=runs_dir, policies_dir=None, episodes=2, workers=1
    )
    assert "lever seed 0" in "\n".join(nothing)


def test_the_command_refuses_bad_workers_and_seed_lists(tmp_path: Path, capsys) -> None:
    _, config_path = tiny_train_config(tmp_path, total=64, name="lever")
    assert main(["ablation", "--configs", str(config_path), "--workers", "0", "--out", str(tmp_path)]) == 2
    assert "--workers must be >= 1, got 0" in capsys.readouterr().err
    assert main(["ablation", "--configs", str(config_path), "--seeds", "3-1", "--out", str(tmp_path)]) == 2
    assert "--seeds takes N, N-M (N <= M)" in capsys.readouterr().err


def test_a_reactive_reference_flies_the_same_layouts_once(tmp_path: Path, monkeypatch, capsys) -> None:
    from helpers import with_other_defaults

    from agents.policies.reactive import StraightAgent

    _, config_path = tiny_train_config(tmp_path, total=64, name="lever")
    out = tmp_path / "ablation"
    lines = compare_configs(
        [config_path],
        [0],
        out,
        runs_dir=tmp_path / "runs",
        episodes=2,
        workers=1,
        reference_agents=["straight"],
    )
    text = "\n".join(lines)
    assert "| straight (reactive, reference) | - | 2 |" in text
    rows = read_records(out / "reference" / "straight.csv")
    assert sorted(r["seed"] for r in rows) == [ABLATION_SEED_START, ABLATION_SEED_START + 1]
    # Its defaults re-tuned since: the old episodes are moved aside and the agent flies anew.
    monkeypatch.setattr(
        StraightAgent, "__init__", with_other_defaults(StraightAgent.__init__, heading_gain=0.5)
    )
    compare_configs([config_path], [0], out, runs_dir=tmp_path / "runs", episodes=2, workers=1,
                    reference_agents=["straight"])  # fmt: skip
    assert "straight's parameters have changed; flying it anew" in capsys.readouterr().out
    assert len(list((out / "reference").glob("straight.csv.bak-*"))) == 1
    rows = read_records(out / "reference" / "straight.csv")
    assert len(rows) == 2 and {json.loads(r["agent_params"])["heading_gain"] for r in rows} == {0.5}
    with pytest.raises(
        ValueError,
        match=re.escape(f"reference agents must be reactive ({', '.join(REACTIVE_AGENTS)}), got 'ppo_flow'"),
    ):
        compare_configs([config_path], [0], out, episodes=2, reference_agents=["ppo_flow"])


def test_a_condition_flies_every_run_and_reference_with_its_env_settings(tmp_path: Path, capsys) -> None:
    config, config_path = tiny_train_config(tmp_path, total=64, name="lever")
    runs_dir = tmp_path / "runs"
    train_seeds(seed_jobs(config, [0], config_path=config_path, runs_dir=runs_dir, ship_to=None))
    out = tmp_path / "dense"
    lines = compare_configs(
        [config_path],
        [0],
        out,
        runs_dir=runs_dir,
        episodes=2,
        workers=1,
        reference_agents=["straight"],
        env={"obstacle_density": 0.18},
    )
    assert "(obstacle_density=0.18), never a test layout" in lines[2]
    for csv_path in (out / "lever" / "seed_0.csv", out / "reference" / "straight.csv"):
        rows = read_records(csv_path)
        assert {(r["factor"], float(r["level"])) for r in rows} == {("obstacle_density", 0.18)}
        assert all(json.loads(r["env_kwargs"])["obstacle_density"] == 0.18 for r in rows)
    # Clean episodes in the same folder are other rows, never counted with the condition's.
    clean = compare_configs([config_path], [0], out, runs_dir=runs_dir, episodes=2, workers=1)
    assert "(clean sensors), never a test layout" in clean[2] and "| lever | 1 | 2 |" in "\n".join(clean)
    assert len(read_records(out / "lever" / "seed_0.csv")) == 4
    # A bad setting is named with its range before anything flies.
    command = ["ablation", "--configs", str(config_path), "--env", "obstacle_density=-1", "--out", str(out)]
    assert main(command) == 2
    assert "obstacle_density must be in [0.0, 1.0], got -1" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main([*command[:3], "--env", "density", "--out", str(out)])
    assert "argument --env: expected KEY=VALUE, got 'density'" in capsys.readouterr().err


def test_each_row_is_compared_with_the_first_on_the_same_layouts(tmp_path: Path) -> None:
    from agents.analysis.paired import compare

    out = tmp_path / "two"
    lines = compare_configs([], [0], out, episodes=2, workers=1, reference_agents=["straight", "bee_ttc"])
    text = "\n".join(lines)
    assert "| failure per seed | − straight (reactive, reference), paired [95 % CI] |" in text
    assert "only an interval that excludes zero tells the two apart" in text
    failures = {
        agent: np.array(
            [
                [
                    0.0 if r["success"] else 1.0
                    for r in sorted(read_records(out / "reference" / f"{agent}.csv"), key=lambda r: r["seed"])
                ]
            ]
        )
        for agent in ("straight", "bee_ttc")
    }
    expected = compare("", failures["bee_ttc"], "", failures["straight"])
    row = next(line for line in lines if line.startswith("| bee_ttc"))
    assert row.endswith(f"| {expected.difference:+.3f} [{expected.low:+.3f}, {expected.high:+.3f}] |")
    assert next(line for line in lines if line.startswith("| straight")).endswith("| - |")


def test_a_confirm_run_flies_the_tiers_fresh_confirmation_layouts(tmp_path: Path) -> None:
    recipes, confirmation = tier_layouts("2"), tier_layouts("2", confirm=True)
    # The recipe layouts end where the confirmation layouts begin; both are the tier's validation layouts.
    assert recipes == range(CAMERA_STUDENT_RECIPE_SEED_START, CAMERA_STUDENT_CONFIRM_SEED_START)
    assert confirmation == range(CAMERA_STUDENT_CONFIRM_SEED_START, TEST_SEED_START)
    assert tier_layouts("1") == range(STUDENT_RECIPE_SEED_START, TEST_SEED_START)  # v1 has no confirmation
    assert confirmation.stop <= TIER_VALIDATION_SEEDS.stop
    tasks = ablation_tasks(
        Path("p.zip"),
        50,
        env_id="FlowNavHard-v1",
        first_layout=confirmation.start,
        layouts_end=confirmation.stop,
    )
    seeds = [t.seed for t in tasks]
    assert seeds == list(range(CAMERA_STUDENT_CONFIRM_SEED_START, CAMERA_STUDENT_CONFIRM_SEED_START + 50))
    assert not set(seeds) & set(recipes)
    # A recipe comparison cannot reach them, however many layouts it asks for.
    with pytest.raises(
        ValueError,
        match=r"^--layouts must be in \[1, 1000\] \(validation layouts from 972,000, short of 973,000\), got 1001$",
    ):
        compare_configs(
            [],
            [0],
            tmp_path / "long",
            episodes=1_001,
            report_only=True,
            reference_agents=["straight"],
            tier="hard",
        )
    out = tmp_path / "hard_confirmation"
    lines = compare_configs(
        [], [0], out, episodes=1, workers=1, reference_agents=["straight"], tier="hard", confirm=True
    )
    row = read_records(out / "reference" / "straight.csv")[0]
    assert row["env_id"] == "FlowNavHard-v1" and row["seed"] == CAMERA_STUDENT_CONFIRM_SEED_START
    text = "\n".join(lines)
    assert lines[0] == "# Confirmation on fresh validation layouts"
    assert "Every run flies fresh confirmation layouts 973,000–973,000 (tier `hard`, FlowNavHard-v1)" in text
    assert "not its recipe layouts (from 972,000), on which the recipes were compared" in text
    assert "Nothing was chosen on these" in text
    # Without --confirm the same tier flies its recipe layouts, and the page says nothing of a confirmation.
    recipe = "\n".join(compare_configs([], [0], tmp_path / "hard", episodes=1, report_only=True, tier="hard"))
    assert recipe.startswith("# Ablations on validation layouts") and "confirmation" not in recipe
    assert "validation layouts 972,000–972,000 (tier `hard`" in recipe


@pytest.mark.parametrize(
    ("tier", "version", "message"),
    [
        (
            None,
            "2",
            "--confirm flies a tier's confirmation layouts: give --tiers TIER (clean, hard, noisy, hard_noisy)",
        ),
        ("hard", "1", "--confirm: suite version 1 has no confirmation layouts (versions with them: 2)"),
    ],
)
def test_confirm_without_a_tier_or_in_a_version_without_confirmation_layouts_is_refused(
    tmp_path: Path, tier: str | None, version: str, message: str
) -> None:
    with pytest.raises(ValueError) as error:
        compare_configs([], [0], tmp_path / "out", episodes=1, tier=tier, suite_version=version, confirm=True)
    assert type(error.value) is ValueError and str(error.value) == message
    assert not (tmp_path / "out").exists()  # refused before anything is written


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (
            [],
            "--confirm flies a tier's confirmation layouts: give --tiers TIER (clean, hard, noisy, hard_noisy)",
        ),
        (
            ["--tiers", "hard", "--suite-version", "1"],
            "--confirm: suite version 1 has no confirmation layouts",
        ),
    ],
)
def test_the_command_refuses_confirm_in_one_line(tmp_path: Path, capsys, options, message) -> None:
    command = ["ablation", "--configs", "c.yaml", "--confirm", *options, "--out", str(tmp_path / "out")]
    assert main(command) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"flownav ablation: error: {message}") and err.count("\n") == 1


def test_the_command_refuses_a_layout_start_outside_validation_in_one_line(tmp_path: Path, capsys) -> None:
    command = ["ablation", "--configs", "c.yaml", "--tiers", "hard", "--layout-start", "1000000"]
    assert main([*command, "--out", str(tmp_path / "out"), "--report-only"]) == 2
    err = capsys.readouterr().err
    assert err == (
        "flownav ablation: error: --layout-start must be a validation layout in [500,000, 999,999], got 1000000\n"
    )
