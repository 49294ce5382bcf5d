"""A recipe for every tier (``per_tier: true``): each run names its tier, flies that tier's id and is named
``<name>_<tier>``; the seed's config file is the tier's; the camera student's recipes ask no tier for privileged
data; bad tiers or missing ones fail in one line naming the value."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from agents.cli import main
from agents.common.yaml_config import ConfigError, from_mapping, load_config
from agents.policies.teachers import check_teacher
from agents.training.multiseed import seed_jobs, write_seed_config
from agents.training.train_config import TrainConfig, for_tier, tier_run_name
from flownav_env.tiers import TIERS_BY_VERSION, check_agent_settings

CAMERA_STUDENT_RECIPES = sorted(Path("configs/experiments").glob("ppo_flow_camera_student*.yaml"))


def _recipe(**keys: object) -> TrainConfig:
    return from_mapping({"name": "student", "env_id": "FlowNav-v1", "per_tier": True, **keys}, TrainConfig)


@pytest.mark.parametrize("tier_name", list(TIERS_BY_VERSION["2"]))
def test_a_per_tier_recipe_flies_each_tier_under_its_own_name(tier_name: str) -> None:
    config = for_tier(_recipe(), tier_name, "r.yaml")
    assert config.env_id == TIERS_BY_VERSION["2"][tier_name].env_id
    assert config.name == tier_run_name("student", tier_name) == f"student_{tier_name}"
    assert not config.per_tier


def test_the_recipes_env_id_picks_the_suite_version() -> None:
    assert for_tier(_recipe(env_id="FlowNav-v0"), "hard", "r.yaml").env_id == "FlowNavHard-v0"


def test_an_ordinary_config_without_a_tier_is_left_as_it_is() -> None:
    config = from_mapping({"name": "plain"}, TrainConfig)
    assert for_tier(config, None, "r.yaml") is config


@pytest.mark.parametrize(
    ("config", "tier_name", "message"),
    [
        (
            _recipe(),
            None,
            r"^r.yaml: a recipe for every tier \('per_tier: true'\) needs --tier, one of clean, hard, "
            r"noisy, hard_noisy$",
        ),
        (
            _recipe(),
            "steep",
            r"^r.yaml: --tier: tier must be one of clean, hard, noisy, hard_noisy, got 'steep'$",
        ),
        (
            from_mapping({"name": "plain"}, TrainConfig),
            "hard",
            r"^r.yaml: --tier hard needs a recipe with "
            r"'per_tier: true'; this config flies FlowNav-v0 only$",
        ),
    ],
)
def test_a_missing_or_bad_tier_is_refused_naming_it(config: TrainConfig, tier_name, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        for_tier(config, tier_name, "r.yaml")


def test_a_per_tier_recipe_on_an_id_that_is_no_tier_is_refused() -> None:
    with pytest.raises(
        ConfigError, match=r"key 'per_tier' needs 'env_id' to be a suite tier's id .*'FlowNavSingle-v0'"
    ):
        _recipe(env_id="FlowNavSingle-v0")


def test_a_seed_of_a_tier_run_writes_the_tiers_config(tmp_path: Path) -> None:
    source = tmp_path / "student.yaml"
    source.write_text(yaml.safe_dump({"name": "student", "env_id": "FlowNav-v1", "per_tier": True}))
    config = for_tier(load_config(source, TrainConfig), "hard_noisy", str(source))
    (job,) = seed_jobs(config, [3], config_path=source, runs_dir=tmp_path / "runs", ship_to=None)
    written = write_seed_config(job)
    assert written == tmp_path / "runs" / "student_hard_noisy" / "seed_3" / "seed_3.yaml"
    saved = load_config(written, TrainConfig)
    assert (saved.name, saved.env_id, saved.per_tier, saved.seed) == (
        "student_hard_noisy",
        "FlowNavHardNoisy-v1",
        False,
        3,
    )
    assert "--tiers FlowNavHardNoisy-v1 --seeds 3" in written.read_text()


def test_train_refuses_a_tier_without_seeds(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    source = tmp_path / "student.yaml"
    source.write_text(yaml.safe_dump({"name": "student", "env_id": "FlowNav-v1", "per_tier": True}))
    assert (
        main(["train", "--config", str(source), "--tiers", "hard", "--runs-dir", str(tmp_path / "runs")]) == 2
    )
    assert capsys.readouterr().err.strip() == (
        "flownav train: error: --tiers hard trains with --seeds (e.g. --seeds 0): give it"
    )
    assert not (tmp_path / "runs").exists()


@pytest.mark.parametrize("path", CAMERA_STUDENT_RECIPES, ids=lambda p: p.stem)
def test_the_camera_student_recipes_ask_no_tier_for_privileged_data_but_the_true_depth_twin(
    path: Path,
) -> None:
    recipe = load_config(path, TrainConfig)
    assert recipe.per_tier and recipe.imitation.teacher == "planner_camera"
    check_teacher(recipe.imitation.teacher, recipe.env, str(path), recipe.imitation.teacher_params)
    twin = path.stem.endswith("_oracle")
    for tier_name in TIERS_BY_VERSION["2"]:
        config = for_tier(recipe, tier_name, str(path))
        # The twin reads true depths (obs_source oracle): a tier allows that only to an agent declared privileged.
        check_agent_settings(config.name, config.env, tier_name, privileged=twin)
        if twin:
            with pytest.raises(ValueError, match="obs_source"):
                check_agent_settings(config.name, config.env, tier_name)


def test_there_are_the_base_recipe_and_its_variants() -> None:
    assert [p.stem for p in CAMERA_STUDENT_RECIPES] == [
        "ppo_flow_camera_student",
        "ppo_flow_camera_student_fine",
        "ppo_flow_camera_student_fine_rounds12",
        "ppo_flow_camera_student_fine_rounds6",
        "ppo_flow_camera_student_fine_rounds6_finetune",
        "ppo_flow_camera_student_fine_rounds6_oracle",
        "ppo_flow_camera_student_fine_rounds6_stack4",
        "ppo_flow_camera_student_rounds6",
    ]
