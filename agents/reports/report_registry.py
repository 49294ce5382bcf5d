"""The registry of every Markdown report in ``results/``, and of the README, whose results block is generated:
for each machine-written one, the committed data it is built from and the writer call that rebuilds it
in-process; for every other one, why it is not regenerated.
:mod:`agents.reports.regeneration` regenerates and compares them.
"""

from __future__ import annotations

import contextlib
import os
import shutil
from collections.abc import Iterator
from functools import partial
from pathlib import Path

from agents.common.locations import REPO_ROOT, RESULTS_DIR
from agents.evaluation.leaderboard import run_leaderboard
from agents.evaluation.suite import run_suite, suite_agents
from agents.evaluation.suite_checks import frozen_physics
from agents.evaluation.sweep import run_sweep
from agents.pages.calibration_page import write_page
from agents.pages.leaderboard_page import write_leaderboard_page
from agents.pages.suite_writer import write_suite_page
from agents.pages.sweep_report import write_sweep_page
from agents.policies import HISTORY_AGENTS
from agents.reports.ablation_entry import AblationSpec
from agents.reports.benchmark_report import write_benchmark, write_readme_results, write_thesis_closed_loop
from agents.reports.error_analysis_report import write_error_analysis_from
from agents.reports.flow_gap_report import write_flow_gap
from agents.reports.report_entry import Report
from agents.reports.reports_not_regenerated import NOT_REGENERATED
from agents.reports.rule_resolution_report import write_rule_resolution
from agents.studies import confirmation, tier_calibration
from flownav_env.tiers import TIER_NAMES


@contextlib.contextmanager
def _repository_as_cwd() -> Iterator[None]:
    """Run a writer from the repository root, then return: the sweep's report prints its config path as given
    (``configs/sweep.yaml``) and reads the config through it, so the text is the same wherever this runs."""
    before = Path.cwd()
    os.chdir(REPO_ROOT)
    try:
        yield
    finally:
        os.chdir(before)


def _sweep(report: Report, folder: Path, *, config: str) -> None:
    # `flownav sweep` leaves --report-only out of the command it prints; the report's "Rebuilt with" line says it.
    with _repository_as_cwd():
        flight = run_sweep(Path(config), folder, report_only=True)
        write_sweep_page(flight, report.command.replace(" --report-only", ""))


def _readme_block(report: Report, folder: Path) -> None:
    """The README's results block written from the committed data into the README in ``folder``: the committed
    README itself when publishing (``--out results``), else a copy of it, so that only the block can differ."""
    readme = folder / Path(report.path).name
    committed = RESULTS_DIR / report.path
    if not (readme.is_file() and readme.samefile(committed)):
        folder.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(committed, readme)
    write_readme_results(RESULTS_DIR, readme)


def _thesis_block(report: Report, folder: Path) -> None:
    # Only the closed-loop paragraph between its markers is written from data; flownav replicate owns the rest.

    root = folder
    for _ in Path(report.path).parent.parts:  # the folder with the layout of results/ that holds the data
        root = root.parent
    write_thesis_closed_loop(root, root / report.path)


# What benchmark.md, the README's results block and the thesis's closed-loop paragraph are written from
# (agents/studies/benchmark_data.py).
BENCHMARK_INPUTS = (
    "leaderboard_episodes.csv",
    "suite_episodes.csv",
    "training_seeds.csv",
    "sweep_episodes.csv",
    "diagnostics/reactive_oracle_episodes.csv",
    "ablation/*/seed_*.csv",
    "ablation/*/*/seed_*.csv",
    "ablation/reference/*.csv",
    "ablation/*/reference/*.csv",
    "policies/*/seed_*.json",
    "policies/*/seed_*.yaml",
)


_LEVERS = tuple(
    f"configs/experiments/ppo_flow_{lever}.yaml"
    for lever in (
        "course",
        "nearness",
        "course_approach",
        "course_approach_stack4",
        "course_approach_curriculum",
        "course_approach_smooth",
        "course_approach_curriculum_slow",
        "teacher",  # the time-to-policy recipe: a teacher start (results/training_performance.md)
    )
)
_CLEAN_ABLATION = ("configs/ppo_flow.yaml", "configs/ppo_oracle.yaml", "configs/ppo_robust.yaml", *_LEVERS)
_CONDITION_ABLATION = ("configs/ppo_flow.yaml", *_LEVERS)
# Recipes tried for the planner's flow student (flownav ablation --tier), the shipped one first.
STUDENT_RECIPES = tuple(
    f"configs/experiments/ppo_flow_planner_student{variant}.yaml" for variant in ("", "_wide", "_finetune")
)
# The camera student's recipe picked on the hard pilot (student_recipes_v2/hard/ablation.md), confirmed on fresh
# layouts: its seeds are shipped, so its page is rebuilt from them.
CAMERA_STUDENT_PICK = "configs/experiments/ppo_flow_camera_student_fine_rounds6.yaml"


# The ablations rebuilt from their committed episodes: the flow-gap levers, clean and in the two robustness
# conditions, and the planner's student's recipes per tier (compared on suite v1's tiers).
ABLATIONS = (
    AblationSpec("ablation", _CLEAN_ABLATION, layouts=100),
    AblationSpec("ablation/density_0.18", _CONDITION_ABLATION, layouts=50, env=(("obstacle_density", 0.18),)),
    AblationSpec("ablation/speed_1.5", _CONDITION_ABLATION, layouts=50, env=(("forward_speed", 1.5),)),
    *(
        AblationSpec(
            f"student_recipes/{name}",
            STUDENT_RECIPES,
            layouts=50,
            seeds=(0, 1),
            reference=("bee_ttc",),
            tier=name,
            suite_version="1",
        )
        for name in TIER_NAMES
    ),
)
# The camera student's pick flown again on suite v2's hard tier's fresh confirmation layouts.
CAMERA_STUDENT_CONFIRMATION = AblationSpec(
    "student_recipes_v2/hard_confirmation",
    (CAMERA_STUDENT_PICK,),
    layouts=50,
    seeds=(0, 1),
    reference=("bee_ttc",),
    tier="hard",
    suite_version="2",
    confirm=True,
)


REPORTS: tuple[Report, ...] = (
    Report(
        "leaderboard.md",
        name="leaderboard",
        command="flownav leaderboard --out results --report-only",
        inputs=("leaderboard_episodes.csv",),
        write=lambda report, folder: write_leaderboard_page(
            run_leaderboard(HISTORY_AGENTS, folder, report_only=True), report.command
        ),
    ),
    Report(
        "sweep.md",
        name="sweep",
        command="flownav sweep --config configs/sweep.yaml --out results --report-only",
        inputs=("sweep_episodes.csv",),
        write=partial(_sweep, config="configs/sweep.yaml"),
    ),
    Report(
        "error_analysis.md",
        name="error-analysis",
        command="flownav error-analysis --episodes results/sweep_episodes.csv --out results",
        inputs=("sweep_episodes.csv", "leaderboard_episodes.csv"),
        write=lambda report, folder: write_error_analysis_from(
            [RESULTS_DIR / "sweep_episodes.csv"],
            folder,
            report.command,
            RESULTS_DIR / "leaderboard_episodes.csv",
        ),
        staged=False,
    ),
    *(
        Report(
            f"sweep_v2/{tier}/sweep.md",
            name=f"sweep-v2-{tier}",
            command=f"flownav sweep --config {config} --out results/sweep_v2/{tier} --report-only",
            inputs=(f"sweep_v2/{tier}/sweep_episodes.csv",),
            write=partial(_sweep, config=config),
        )
        for tier, config in (("clean", "configs/sweep_v2.yaml"), ("hard", "configs/sweep_v2_hard.yaml"))
    ),
    Report(
        "sweep_v2/error_analysis.md",
        name="error-analysis-v2",
        command="flownav error-analysis --episodes results/sweep_v2/clean/sweep_episodes.csv "
        "--episodes results/sweep_v2/hard/sweep_episodes.csv --baseline results/suite_episodes.csv "
        "--compare-with results/sweep_episodes.csv results/leaderboard_episodes.csv --out results/sweep_v2",
        inputs=(
            "sweep_v2/clean/sweep_episodes.csv",
            "sweep_v2/hard/sweep_episodes.csv",
            "suite_episodes.csv",
            "sweep_episodes.csv",
            "leaderboard_episodes.csv",
        ),
        write=lambda report, folder: write_error_analysis_from(
            [RESULTS_DIR / "sweep_v2" / tier / "sweep_episodes.csv" for tier in ("clean", "hard")],
            folder,
            report.command,
            RESULTS_DIR / "suite_episodes.csv",
            compare_with=(RESULTS_DIR / "sweep_episodes.csv", RESULTS_DIR / "leaderboard_episodes.csv"),
        ),
        staged=False,
    ),
    *(spec.report() for spec in ABLATIONS),
    Report(
        "suite_v1/suite_calibration/calibration.md",
        name="calibrate-tiers",
        command="flownav calibrate-tiers --out results/suite_v1/suite_calibration --report-only",
        inputs=(
            "suite_v1/suite_calibration/calibration_episodes.csv",
            "suite_v1/suite_calibration/sensor_pilot_episodes.csv",
        ),
        write=lambda report, folder: tier_calibration.write_calibration(
            folder, report.command, report_only=True
        ),
    ),
    Report(
        "benchmark.md",
        name="benchmark",
        command="flownav reports --out results --only benchmark",
        inputs=BENCHMARK_INPUTS,
        write=lambda report, folder: write_benchmark(folder, folder, report.command),
    ),
    Report(
        "../README.md",
        name="readme-results",
        command="flownav reports --out results --only readme-results",
        inputs=BENCHMARK_INPUTS,
        write=_readme_block,
        staged=False,
    ),
    *(
        Report(
            f"thesis/{file}",
            name=name,
            command=f"flownav reports --out results --only {name}",
            inputs=(*BENCHMARK_INPUTS, f"thesis/{file}"),
            write=_thesis_block,
        )
        for file, name in (("DISCUSSION.md", "thesis-discussion"), ("README.md", "thesis-readme"))
    ),
    Report(
        "confirmation/confirmation.md",
        name="confirm",
        command="flownav confirm --out results/confirmation --report-only",
        # The fresh flights are staged into the folder the report is written to; the search's are read
        # from results/ablation/ where they lie.
        inputs=("confirmation/*.csv", "ablation/*/*/seed_*.csv"),
        write=lambda report, folder: confirmation.write_confirmation(
            folder, report.command, report_only=True
        ),
    ),
    Report(
        "suite.md",
        name="suite",
        command="flownav suite --out results --report-only",
        inputs=(
            "suite_episodes.csv",
            "suite_v2_calibration/*.csv",
            "suite_v2_calibration/sensitivity/*.csv",
            "suite_reflight.csv",
            # The logged choices per agent (flownav decision-log writes it beside its page).
            "decision_log.csv",
        ),
        write=lambda report, folder: write_suite_page(
            run_suite(suite_agents("2"), folder, report_only=True, version="2"), report.command
        ),
    ),
    Report(
        "suite_v2_calibration/calibration.md",
        name="suite-checks",
        command="flownav reports --out results --only suite-checks",
        inputs=("suite_v2_calibration/*.csv", "suite_v2_calibration/sensitivity/*.csv"),
        write=lambda report, folder: write_page(folder, report.command, frozen_physics()),
    ),
    Report(
        "suite_v1/suite.md",
        name="suite-v1",
        command="flownav suite --suite-version 1 --out results/suite_v1 --report-only",
        inputs=("suite_v1/suite_episodes.csv", "suite_v1/sensor_reading/*.csv", "suite_v1/lane/*.csv"),
        write=lambda report, folder: write_suite_page(
            run_suite(suite_agents("1"), folder, report_only=True, version="1"), report.command
        ),
    ),
    Report(
        "flow_gap.md",
        name="flow-gap",
        command="flownav reports --out results --only flow-gap",
        inputs=(*BENCHMARK_INPUTS, "confirmation/*.csv"),
        write=lambda report, folder: write_flow_gap(folder, folder, report.command),
    ),
    CAMERA_STUDENT_CONFIRMATION.report(),
    Report(
        "rule_resolution/rule_resolution.md",
        name="rule-resolution",
        command="flownav rule-resolution --out results/rule_resolution --report-only",
        inputs=("rule_resolution/episodes.csv",),
        write=lambda report, folder: write_rule_resolution(folder, report.command, report_only=True),
    ),
    *NOT_REGENERATED,
)
