"""The reports of ``results/`` that are not regenerated, each with why: hand-written prose, measurements by the
code of their time, pilots whose policies were not shipped, and stale pages kept for comparison. Part of
:data:`agents.reports.report_registry.REPORTS`."""

from __future__ import annotations

from agents.reports.report_entry import Report, not_regenerated

PROSE = "hand-written prose"
STALE = "stale, kept for comparison as the code of its time wrote it (results/README.md)"

NOT_REGENERATED: tuple[Report, ...] = (
    Report(
        "student_recipes_v2/hard/ablation.md",
        reason="a pilot whose policies, but the pick's, were not shipped: flownav ablation wrote it from the run "
        "folders its training left in runs/, which a checkout does not keep (the commands are in the report; its "
        "episodes are committed beside it; the pick's seeds are results/policies/"
        "ppo_flow_camera_student_fine_rounds6_hard/)",
    ),
    Report(
        "student_recipes_v2/hard_stack/ablation.md",
        reason="a pilot whose frame-stacked policies were not shipped: flownav ablation wrote it from the run folders "
        "its training left in runs/, which a checkout does not keep (the commands are in the report; its episodes "
        "are committed beside it)",
    ),
    Report(
        "student_recipes_v2/hard_rounds12/ablation.md",
        reason="a pilot whose twelve-round policies were not shipped: flownav ablation wrote it from the run folders "
        "its training left in runs/, which a checkout does not keep (the commands are in the report; its episodes "
        "are committed beside it)",
    ),
    *(
        Report(
            f"student_recipes_v2/{tier_name}/ablation.md",
            reason="a pilot whose policies were not shipped: flownav ablation wrote it from the run folders its "
            "training left in runs/, which a checkout does not keep (the commands are in the report; its episodes "
            "are committed beside it)",
        )
        for tier_name in ("clean", "noisy")
    ),
    Report(
        "observed_teacher_recipes/ablation.md",
        reason="the observed-teacher search (configs/decisions.yaml, observed_teacher_recipes), whose policies were "
        "not shipped: flownav ablation wrote it from the run folders its training left in runs/, which a checkout "
        "does not keep (the commands are in the report; its episodes are committed beside it)",
    ),
    Report(
        "ablation/lever_lab_notes.md",
        reason="the lever search's lab notebook, hand-written lever by lever as each was judged and kept as it was: its "
        "figures are those of their day (the current ones are flow_gap.md's and ablation.md's)",
    ),
    *not_regenerated(
        PROSE,
        "README.md",
        "camera_reference/README.md",
        "student_recipes_v2/hard_confirmation/README.md",
        "diagnostics/README.md",
        "renderer_check/README.md",
        "sweep_fast20/README.md",
        "sweep_thesis_range/README.md",
        "throughput/README.md",
        "unfinished/README.md",
    ),
    Report(
        "estimator_performance.md",
        reason="a measurement by the code of its time: flownav bench estimator measures Table 3 and the targets "
        "again, but no longer its section on per-point depth loops (estimator_performance_depth_stage.csv) nor "
        "the full backward search (its ratio column and the flow stage's ratio derived from it)",
    ),
    *not_regenerated(
        "a measurement by the code of its time: flownav bench env measures steps/s, the stage split and the "
        "targets again, but no longer its Default resolution and FAST threshold sections",
        "env_performance.md",
        "renderer_check/env_performance.md",
    ),
    Report(
        "training_performance.md",
        reason="a measurement by the code of its time: flownav bench recipe measures the minutes per seed and "
        "states the quality again, but no longer the recorded minutes column nor its Seeds per hour section",
    ),
    Report(
        "student_recipes_v2/recipe_speed/training_performance.md",
        reason="a measurement by the code of its time: flownav bench recipe measures the camera student's minutes "
        "per seed again (the command is in the report)",
    ),
    Report(
        "decision_log.md",
        reason="read from the repository's history as well as its files: flownav decision-log --out results writes "
        "it again (tests/agents/studies/test_decision_log.py checks it against git where the history is there)",
    ),
    Report(
        "isolation_cost.md",
        reason="a measurement of time, not a report from data: flownav bench isolation measures it again (the "
        "command is in the report)",
    ),
    Report(
        "depth_yield.md",
        reason="a measurement by the code of its time: flownav bench yield flies the in-scene variants again, but "
        "no longer its ICL-NUIM section",
    ),
    *not_regenerated(
        STALE,
        "sweep_fast20/sweep.md",
        "sweep_thesis_range/sweep.md",
        "sweep_thesis_range/benchmark.md",
        "renderer_check/sweep.md",
        "bee_tuning/ranking.md",
    ),
    *not_regenerated(
        "flownav tune has no report-only path: running it again resumes the study, which may fly episodes",
        "tuning/bee/tuning.md",
        "tuning/bee_robust/tuning.md",
        "tuning/vfh/tuning.md",
    ),
)
