"""The three disjoint ranges of env seeds (layouts) FlowNav draws from, written here and nowhere else.

| range | seeds | used for |
|---|---|---|
| training | ``[0, VALIDATION_SEED_START)`` | the layouts policies learn on, and tuning reactive gains |
| validation | ``[VALIDATION_SEED_START, TEST_SEED_START)`` | every decision: checkpoint choice during training, thresholds, ablations (from ``ABLATION_SEED_START``) |
| test | ``[TEST_SEED_START, ...)`` | only the reported tables (evaluation, sweeps, the demo) |

Sub-ranges with one use each:

| sub-range | seeds | used for |
|---|---|---|
| ablation (validation) | ``ABLATION_SEED_START ..`` (900,000-900,099 used) | the flow-gap lever search |
| confirmation (validation) | ``CONFIRMATION_SEED_START ..`` | confirming a pick on layouts its search never saw |
| tier calibration (validation) | ``TIER_CALIBRATION_SEED_START ..`` | choosing the suite's tier settings |
| sensor pilot (validation) | ``SENSOR_PILOT_SEED_START ..`` | trying versions of the realistic sensor before freezing it |
| sensor reading (validation) | ``SENSOR_READING_SEED_START ..`` | the noisy tier at other readings of its specifications |
| planner tuning (validation) | ``PLANNER_TUNING_SEED_START ..`` | tuning the privileged ``planner`` and measuring its failure per tier |
| student check (validation) | ``STUDENT_CHECK_SEED_START ..`` | flying the planner's flow-only student against ``bee_ttc`` per tier (``flownav evaluate --seed-start``) |
| student recipes (validation) | ``STUDENT_RECIPE_SEED_START ..`` | recipes for the planner's student compared per tier (``flownav ablation --tier``) |
| lane check (validation) | ``LANE_SEED_START ..`` | whether agents leave the capsule field for the free lane beside it (``agents/evaluation/lane.py``) |
| camera-limited references (validation) | ``CAMERA_REFERENCE_SEED_START ..`` | checking the camera-limited planners (``planner_camera``, ``planner_camera_observed``) against ``planner`` on a field across the whole lateral bounds (``results/camera_reference/``) |
| suite v2 checks (validation) | ``SUITE_V2_CHECK_SEED_START ..`` | the privileged references' feasibility checks of suite v2's tiers, before the freeze |
| suite v2 sensor readings (validation) | ``SUITE_V2_SENSOR_READING_SEED_START ..`` | v2's noisy tiers at other readings of the velocity specification |
| camera student recipes (validation) | ``CAMERA_STUDENT_RECIPE_SEED_START ..`` | recipes for the camera-limited planner's student compared per suite v2 tier (``flownav ablation --tiers T --suite-version 2``) |
| camera student confirmation (validation) | ``CAMERA_STUDENT_CONFIRM_SEED_START ..`` | the recipe picked there flown again on fresh layouts, per suite v2 tier (``flownav ablation --tiers T --suite-version 2 --confirm``) |
| rule resolutions (validation) | ``RULE_RESOLUTION_SEED_START ..`` (1,000) | the flow rules at finer depth histograms, per suite v2 hard tier, paired against their own resolution (``flownav rule-resolution``, ``results/rule_resolution/``) |
| rule resolution refinement (validation) | ``RULE_RESOLUTION_REFINE_SEED_START ..`` (1,000) | the search's nearest rule at its nearest resolution and at the finer bins alone, on fresh layouts, paired against its own resolution |
| rule resolution confirmation (validation) | ``RULE_RESOLUTION_CONFIRM_SEED_START ..`` (1,000) | a resolution picked by the search or the refinement flown again against the rule's own on fresh layouts |
| observed-teacher recipes (validation) | ``OBSERVED_TEACHER_RECIPE_SEED_START ..`` (1,000) | the flow students that follow an observation-limited teacher, compared per recipe on the hard tier (``configs/decisions.yaml``, ``observed_teacher_recipes``; ``flownav ablation --tiers hard --layout-start 977000``) |
| observed-teacher confirmation (validation) | ``OBSERVED_TEACHER_CONFIRM_SEED_START ..`` (1,000) | the recipe picked there flown again beside the best rule on fresh layouts, paired |
| suite (test, frozen) | ``SUITE_SEED_STARTS[version] .. + SUITE_LAYOUTS`` | each suite version's table and ``flownav score``; nothing is chosen by looking at it (v1 from 2,000,000, v2 from 3,000,000) |

Per tier (``TIER_TRAINING_SEEDS``, ``TIER_VALIDATION_SEEDS``; ``trained_tiers.tier_seed_split``): a policy
trained for a suite tier learns on the training range and is judged on the tier's validation range, both flown
with the tier's course and sensor. Every tier has the same ranges, as every tier of the suite flies the same test
layouts: a seed fixes the field and the tier its speed, density and sensor, so a tier's training layouts are
never a test one.

A layout is a function of its seed alone, so disjoint ranges mean no reported layout was ever trained on or
used to pick anything.
"""

from __future__ import annotations

VALIDATION_SEED_START = 500_000
TEST_SEED_START = 1_000_000

# A training run's own seed k (its config's ``seed``, one of ``flownav train --seeds``) sets where its env workers
# start: worker i first resets on layout k * RUN_SEED_STRIDE + i. With consecutive starts instead, run k's
# second worker would replay run k + 1's first worker layout for layout, and the runs would not be independent.
RUN_SEED_STRIDE = 1_000
MAX_RUN_SEED = VALIDATION_SEED_START // RUN_SEED_STRIDE - 1


# Validation layouts for comparing training runs and ablations (``flownav ablation``): past the starts of the
# checkpoint-selection streams of run seeds below 400 (checkpoint_selection_seed), and before the test range.
ABLATION_SEED_START = 900_000
# Fresh validation layouts for confirming a selection made on the ablation layouts (flownav confirm).
CONFIRMATION_SEED_START = 910_000
# Validation layouts on which the suite's tiers are calibrated (flownav calibrate-tiers).
TIER_CALIBRATION_SEED_START = 920_000
# Validation layouts on which versions of the suite's realistic sensor were tried (sensor_pilot_episodes.csv).
SENSOR_PILOT_SEED_START = 930_000
# Validation layouts on which the noisy tier is flown at other readings of its sensor specifications.
SENSOR_READING_SEED_START = 940_000
# Validation layouts on which the privileged planner (agents/policies/planner.py) is tuned and measured.
PLANNER_TUNING_SEED_START = 950_000
# Validation layouts on which the planner's distilled student (ppo_flow_planner_student) is checked per tier.
STUDENT_CHECK_SEED_START = 960_000
# Validation layouts on which recipes for that student are compared per tier (flownav ablation --tier): past the
# first check's 100.
STUDENT_RECIPE_SEED_START = 960_100
# Validation layouts on which every agent is flown once per tier to see whether it leaves the capsule field for the
# free lane beside it (agents/evaluation/lane.py): past the student recipes' 100.
LANE_SEED_START = 960_200
# Validation layouts on which the camera-limited planners (agents/policies/planner_camera.py) are checked against
# the planner with the map (results/camera_reference/): past the lane check's 25 (960,200-960,224).
CAMERA_REFERENCE_SEED_START = 960_300
# Validation layouts on which suite v2's tiers are checked for feasibility before they are frozen (the privileged
# planner and the camera-limited reference; results/suite_v2_calibration/).
SUITE_V2_CHECK_SEED_START = 970_000
# Validation layouts on which suite v2's noisy tiers are flown at other readings of the velocity specification
# (the sensitivity table): past the checks' 1,000.
SUITE_V2_SENSOR_READING_SEED_START = 971_000
# Validation layouts on which recipes for the camera-limited planner's flow student (ppo_flow_camera_student, one
# recipe per suite v2 tier) are compared per tier (flownav ablation --tiers, suite version 2): past the sensor
# readings' 1,000.
CAMERA_STUDENT_RECIPE_SEED_START = 972_000
# Fresh validation layouts on which a camera student recipe picked on the ones above is confirmed against the rule:
# past the recipes' 1,000.
CAMERA_STUDENT_CONFIRM_SEED_START = 973_000
# Validation layouts on which the flow rules fly at finer depth histograms than the default, per suite v2 hard tier
# (agents/studies/rule_resolution.py): past the camera student's confirmation's 1,000 (973,000-973,999).
RULE_RESOLUTION_SEED_START = 974_000
# Fresh validation layouts on which a resolution picked on the ones above is confirmed: past their 1,000.
RULE_RESOLUTION_CONFIRM_SEED_START = 975_000
# Fresh validation layouts on which the rule resolution study's second stage (the refinement) flies: past the
# confirmation's 1,000.
RULE_RESOLUTION_REFINE_SEED_START = 976_000
# Validation layouts on which the flow students that follow an observation-limited teacher are compared per recipe
# (configs/decisions.yaml, observed_teacher_recipes): past the rule resolution refinement's 1,000.
OBSERVED_TEACHER_RECIPE_SEED_START = 977_000
# Fresh validation layouts on which the recipe picked there is confirmed against the best rule: past those 1,000.
OBSERVED_TEACHER_CONFIRM_SEED_START = 978_000
# How many layouts each of the three rule resolution ranges holds (the next use starts past them).
RULE_RESOLUTION_LAYOUTS = 1_000
# Per suite version, where ``flownav ablation --tiers`` starts its validation layouts: v1's student recipes, v2's
# camera student's.
TIER_RECIPE_SEED_STARTS = {"1": STUDENT_RECIPE_SEED_START, "2": CAMERA_STUDENT_RECIPE_SEED_START}
# Per suite version, where ``flownav ablation --tiers --confirm`` starts its fresh validation layouts: a recipe
# picked on the version's recipe layouts above flies again where nothing was chosen. v1 has none (its student's
# recipes were never confirmed on a range of their own).
TIER_CONFIRM_SEED_STARTS = {"2": CAMERA_STUDENT_CONFIRM_SEED_START}
# Each suite version's frozen test layouts: no run of the project touched them before that version was frozen.
SUITE_SEED_STARTS = {"1": 2_000_000, "2": 3_000_000}
# The current (newest) version's first frozen layout.
SUITE_SEED_START = SUITE_SEED_STARTS[max(SUITE_SEED_STARTS)]
SUITE_LAYOUTS = 300


# Per suite tier: the layouts a policy for that tier trains on, and those that decide anything about it
# (agents.policies.trained_tiers.tier_seed_split names the tier); the same two ranges for every tier.
TIER_TRAINING_SEEDS = range(0, VALIDATION_SEED_START)
TIER_VALIDATION_SEEDS = range(STUDENT_CHECK_SEED_START, TEST_SEED_START)


def suite_seeds(layouts: int = SUITE_LAYOUTS, version: str | None = None) -> range:
    """The first ``layouts`` frozen test layouts of suite ``version`` (default: the newest).

    Raises:
        ValueError: ``layouts`` is not between 1 and :data:`SUITE_LAYOUTS`, or an unknown version.
    """
    if isinstance(layouts, bool) or not isinstance(layouts, int) or not 1 <= layouts <= SUITE_LAYOUTS:
        raise ValueError(f"suite layouts must be an integer in [1, {SUITE_LAYOUTS}], got {layouts!r}")
    version = max(SUITE_SEED_STARTS) if version is None else str(version)
    if version not in SUITE_SEED_STARTS:
        raise ValueError(f"suite version must be one of {', '.join(SUITE_SEED_STARTS)}, got {version!r}")
    start = SUITE_SEED_STARTS[version]
    return range(start, start + layouts)


def training_env_seed(run_seed: int) -> int:
    """The first layout seed of training run ``run_seed``'s env workers (worker i adds i)."""
    return run_seed * RUN_SEED_STRIDE


def checkpoint_selection_seed(run_seed: int) -> int:
    """The first layout seed of training run ``run_seed``'s held-out evaluation env (a validation seed)."""
    return VALIDATION_SEED_START + run_seed * RUN_SEED_STRIDE


def validation_layouts_from(start: int) -> range:
    """The validation layouts from ``start`` on, short of the test layouts: a search's own range, declared in
    ``configs/decisions.yaml`` before its flights.

    Raises:
        ValueError: ``start`` outside the validation layouts.
    """
    if (
        isinstance(start, bool)
        or not isinstance(start, int)
        or not VALIDATION_SEED_START <= start < TEST_SEED_START
    ):
        raise ValueError(
            f"--layout-start must be a validation layout in [{VALIDATION_SEED_START:,}, {TEST_SEED_START - 1:,}], "
            f"got {start!r}"
        )
    return range(start, TEST_SEED_START)
