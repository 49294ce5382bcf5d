"""The seed ranges: disjoint, and each tier's training split apart from every test layout."""

from __future__ import annotations

import pytest

from agents.common.seeds import (
    ABLATION_SEED_START,
    PLANNER_TUNING_SEED_START,
    STUDENT_CHECK_SEED_START,
    SUITE_SEED_START,
    TEST_SEED_START,
    VALIDATION_SEED_START,
    suite_seeds,
    validation_layouts_from,
)
from agents.policies.trained_tiers import tier_seed_split
from flownav_env.tiers import TIER_NAMES


@pytest.mark.parametrize("tier", TIER_NAMES)
def test_each_tier_trains_and_validates_apart_from_the_test_layouts(tier: str) -> None:
    split = tier_seed_split(tier)
    assert split.tier == tier
    assert split.training.start == 0 and split.training.stop == VALIDATION_SEED_START
    assert VALIDATION_SEED_START <= split.validation.start and split.validation.stop <= TEST_SEED_START
    assert not set(range(split.training.start, split.training.stop)) & set(split.validation)
    assert split.validation.stop <= SUITE_SEED_START and max(split.training) < min(suite_seeds())


def test_a_tiers_validation_layouts_are_none_the_other_decisions_used() -> None:
    validation = tier_seed_split("hard").validation
    for other in (ABLATION_SEED_START, PLANNER_TUNING_SEED_START):
        assert other not in validation
    assert validation.start == STUDENT_CHECK_SEED_START


def test_an_unknown_tier_is_refused_naming_the_tiers() -> None:
    with pytest.raises(ValueError, match=r"tier must be one of clean, hard, noisy, hard_noisy, got 'easy'"):
        tier_seed_split("easy")


def test_the_tier_validation_uses_take_their_own_layouts_in_turn() -> None:
    from agents.common.seeds import LANE_SEED_START, STUDENT_RECIPE_SEED_START, TIER_VALIDATION_SEEDS

    # The first check flew 100 layouts, the recipe comparisons 100 (50 used); the lane check starts past both.
    assert STUDENT_CHECK_SEED_START + 100 == STUDENT_RECIPE_SEED_START
    assert STUDENT_RECIPE_SEED_START + 100 == LANE_SEED_START
    assert LANE_SEED_START in TIER_VALIDATION_SEEDS


def test_the_camera_student_recipes_fly_validation_layouts_no_earlier_v2_use_took() -> None:
    from agents.common.seeds import (
        CAMERA_STUDENT_CONFIRM_SEED_START,
        CAMERA_STUDENT_RECIPE_SEED_START,
        SUITE_V2_SENSOR_READING_SEED_START,
        TIER_RECIPE_SEED_STARTS,
        TIER_VALIDATION_SEEDS,
    )
    from flownav_env.tiers import SUITE_VERSIONS

    # v2's checks took 970,000-970,999, its sensor readings 971,000-971,999; the recipes' 1,000 come after.
    assert CAMERA_STUDENT_RECIPE_SEED_START == SUITE_V2_SENSOR_READING_SEED_START + 1_000
    assert CAMERA_STUDENT_RECIPE_SEED_START + 1_000 - 1 in TIER_VALIDATION_SEEDS
    assert CAMERA_STUDENT_RECIPE_SEED_START + 1_000 <= TEST_SEED_START <= min(suite_seeds(version="2"))
    assert set(TIER_RECIPE_SEED_STARTS) == set(SUITE_VERSIONS)
    assert TIER_RECIPE_SEED_STARTS["2"] == CAMERA_STUDENT_RECIPE_SEED_START
    assert CAMERA_STUDENT_CONFIRM_SEED_START == CAMERA_STUDENT_RECIPE_SEED_START + 1_000
    assert CAMERA_STUDENT_CONFIRM_SEED_START + 1_000 <= TEST_SEED_START


def test_each_versions_confirmation_layouts_follow_its_recipe_layouts_apart_from_them() -> None:
    from agents.common.seeds import (
        CAMERA_STUDENT_CONFIRM_SEED_START,
        TIER_CONFIRM_SEED_STARTS,
        TIER_RECIPE_SEED_STARTS,
        TIER_VALIDATION_SEEDS,
    )
    from flownav_env.tiers import SUITE_VERSIONS

    assert set(TIER_CONFIRM_SEED_STARTS) <= set(SUITE_VERSIONS)
    assert TIER_CONFIRM_SEED_STARTS["2"] == CAMERA_STUDENT_CONFIRM_SEED_START
    for version, start in TIER_CONFIRM_SEED_STARTS.items():
        # Past the 1,000 recipe layouts of the same version, and a tier's validation layouts, never a test one.
        assert start >= TIER_RECIPE_SEED_STARTS[version] + 1_000
        assert start in TIER_VALIDATION_SEEDS and start + 1_000 <= TEST_SEED_START


def test_the_rule_resolution_ranges_follow_the_camera_students_and_each_other_apart() -> None:
    from agents.common.seeds import (
        CAMERA_STUDENT_CONFIRM_SEED_START,
        RULE_RESOLUTION_CONFIRM_SEED_START,
        RULE_RESOLUTION_LAYOUTS,
        RULE_RESOLUTION_REFINE_SEED_START,
        RULE_RESOLUTION_SEED_START,
        TIER_VALIDATION_SEEDS,
    )

    # The camera student's confirmation took 973,000-973,999; the search's 1,000 and the confirmation's follow.
    assert RULE_RESOLUTION_SEED_START == CAMERA_STUDENT_CONFIRM_SEED_START + 1_000
    assert RULE_RESOLUTION_CONFIRM_SEED_START == RULE_RESOLUTION_SEED_START + RULE_RESOLUTION_LAYOUTS
    # The refinement's 1,000 follow the confirmation's.
    assert RULE_RESOLUTION_REFINE_SEED_START == RULE_RESOLUTION_CONFIRM_SEED_START + RULE_RESOLUTION_LAYOUTS
    last = RULE_RESOLUTION_REFINE_SEED_START + RULE_RESOLUTION_LAYOUTS - 1
    assert last in TIER_VALIDATION_SEEDS and last < TEST_SEED_START


def test_the_observed_teacher_ranges_follow_the_rule_resolution_ones_apart() -> None:
    from agents.common.seeds import (
        OBSERVED_TEACHER_CONFIRM_SEED_START,
        OBSERVED_TEACHER_RECIPE_SEED_START,
        RULE_RESOLUTION_LAYOUTS,
        RULE_RESOLUTION_REFINE_SEED_START,
        TIER_VALIDATION_SEEDS,
    )

    assert OBSERVED_TEACHER_RECIPE_SEED_START == RULE_RESOLUTION_REFINE_SEED_START + RULE_RESOLUTION_LAYOUTS
    assert OBSERVED_TEACHER_CONFIRM_SEED_START == OBSERVED_TEACHER_RECIPE_SEED_START + 1_000
    last = OBSERVED_TEACHER_CONFIRM_SEED_START + 1_000 - 1
    assert last in TIER_VALIDATION_SEEDS and last < TEST_SEED_START


def test_a_search_flies_its_own_declared_validation_layouts() -> None:
    assert validation_layouts_from(977_000) == range(977_000, TEST_SEED_START)
    for bad in (TEST_SEED_START, 499_999, True):
        with pytest.raises(
            ValueError, match=r"^--layout-start must be a validation layout in \[500,000, 999,999\], got "
        ):
            validation_layouts_from(bad)
