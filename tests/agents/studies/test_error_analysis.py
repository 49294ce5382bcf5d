"""The error analysis on synthetic sweeps with known answers: tolerance levels, the dose-response fit, which
agents it covers, the report and the command line's refusals."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from helpers import EPISODE

from agents.analysis.dose_response import cell_quality, fit_dose_response, format_p
from agents.analysis.episode_record import is_flow_agent
from agents.analysis.weaving import turning_and_rotation_error
from agents.cli import main
from agents.pages.wording import render_report
from agents.reports.error_analysis_report import (
    ErrorAnalysisValues,
    SweepSections,
    report_values,
    write_error_analysis,
)
from agents.studies.error_analysis import best_learned_flow_agent, neutral_level, tolerance_table


def _cell(
    agent: str, factor: str, level: float, failures: int, n: int = 100, error: float = 0.04
) -> list[dict]:
    return [
        {
            "agent": agent,
            "factor": factor,
            "level": level,
            "seed": 1_000_000 + i,
            "success": i >= failures,
            "median_depth_error": error,
            "mean_points_valid": 120.0,
            "env_kwargs": json.dumps({"obs_source": "flow"}),
        }
        for i in range(n)
    ]


def _sweep() -> list[dict]:
    rows = _cell("bee", "clean", 0.0, 20)
    # Rotation error: harmless up to 0.1, then worse, doubling at 0.5.
    for level, failures in ((0.05, 22), (0.1, 25), (0.3, 33), (0.5, 45), (1.0, 70)):
        rows += _cell("bee", "rotation_error", level, failures)
    # Speed on both sides of its neutral 1 m/s: slower is harmless, faster breaks at once.
    for level, failures in ((0.5, 10), (0.25, 18), (2.0, 60)):
        rows += _cell("bee", "forward_speed", level, failures)
    return rows


def test_neutral_levels_are_the_env_defaults() -> None:
    assert neutral_level("rotation_error") == 0.0
    assert neutral_level("brightness") == 1.0
    assert neutral_level("forward_speed") == 1.0
    with pytest.raises(ValueError, match="'wind' is not an env setting, so it has no neutral level"):
        neutral_level("wind")


def test_tolerance_scans_outward_from_neutral_on_each_side() -> None:
    table = {(r["factor"], r["side"]): r for r in tolerance_table(_sweep())}
    rotation = table[("rotation_error", "above")]
    assert rotation["clean_failure"] == pytest.approx(0.2)
    assert rotation["tolerated_level"] == 0.1  # 0.25 is inside [0.13, 0.29]; 0.33 is not
    assert rotation["doubling_level"] == 0.5  # 0.45 >= 2 x 0.2 and above the interval
    assert rotation["breaks"] and rotation["worst_level"] == 1.0
    # 0.33 at 0.3 has [0.25, 0.43], overlapping the clean [0.13, 0.29]; 0.45 at 0.5 has [0.36, 0.55].
    assert (rotation["breaking_level"], rotation["breaking_failure"]) == (0.5, pytest.approx(0.45))
    assert rotation["thesis"].startswith("at 8 %")
    slower = table[("forward_speed", "below")]
    assert slower["levels"] == [0.5, 0.25] and slower["tolerated_level"] == 0.25 and not slower["breaks"]
    assert slower["breaking_level"] is None
    faster = table[("forward_speed", "above")]
    assert faster["tolerated_level"] == 1.0 and faster["doubling_level"] == 2.0


def test_doubling_is_undefined_when_twice_clean_exceeds_one() -> None:
    rows = _cell("bee", "clean", 0.0, 60) + _cell("bee", "brightness", 0.3, 95)
    (row,) = tolerance_table(rows)
    assert row["side"] == "below" and row["doubling_level"] is None and row["breaks"]


def test_oracle_and_blind_agents_are_left_out_of_the_dose_response() -> None:
    flow, oracle = _cell("ppo_flow@2", "clean", 0.0, 1, n=1), _cell("ppo_oracle", "clean", 0.0, 1, n=1)
    oracle[0]["env_kwargs"] = json.dumps({"obs_source": "oracle"})
    assert is_flow_agent(flow[0]) and not is_flow_agent(oracle[0])
    assert not is_flow_agent(_cell("straight", "clean", 0.0, 1, n=1)[0])
    # Without recorded settings, configs/agents.yaml says what the agent sees.
    assert is_flow_agent({"agent": "ppo_flow@2"}) and not is_flow_agent({"agent": "ppo_oracle@0"})
    with pytest.raises(ValueError, match="cannot tell whether 'my_recipe' steers by flow"):
        is_flow_agent({"agent": "my_recipe"})


def _law_cells(law, rng: np.random.Generator, layouts: int = 150, outliers: bool = False) -> list[dict]:
    """Episodes of sensor cells (three factors × six levels, and clean) whose depth quality is set per cell and
    whose failures follow ``law(error, points, outlier_share)``; every cell flies the same layouts."""
    rows = []
    cells = [("clean", 0.0)] + [
        (f, float(k)) for f in ("depth_noise", "rotation_error", "translation_error") for k in range(1, 7)
    ]
    for factor, level in cells:
        error = float(np.exp(rng.uniform(np.log(0.02), np.log(0.5))))
        points = float(rng.uniform(50, 200))
        share = float(rng.uniform(0.0, 0.6))
        probability = law(error, points, share)
        for seed in range(layouts):
            row = {
                "agent": "bee",
                "factor": factor,
                "level": level,
                "seed": 1_000_000 + seed,
                "success": bool(rng.random() >= probability),
                "median_depth_error": error,
                "mean_points_valid": points,
            }
            if outliers:
                row["mean_depth_outlier_share"] = share
            rows.append(row)
    return rows


def test_the_dose_response_recovers_a_known_logistic_law() -> None:
    def law(error: float, points: float, share: float) -> float:
        return 1.0 / (1.0 + math.exp(-(2.0 + 1.5 * math.log(error))))

    rows = _law_cells(law, np.random.default_rng(1))
    fit = fit_dose_response(rows, cell_quality(rows))
    assert fit["episodes"] == 19 * 150 and fit["layouts"] == 150
    low, high = fit["conf_int"]["log_depth_error"]
    assert low < 1.5 < high
    low, high = fit["conf_int"]["valid_points_per_100"]
    assert low < 0.0 < high  # points do not matter in this law
    assert fit["wald_df"] == 3 and fit["wald_pvalue"] > 0.001  # the factors act only through the error


def test_a_cells_quality_comes_from_its_full_course_flights() -> None:
    rows = _cell("bee", "depth_noise", 0.4, 50, n=100, error=0.04)
    for row in rows[:50]:  # the failed ones flew short and saw worse depths
        row["median_depth_error"] = 0.4
    quality = cell_quality(rows)[("depth_noise", 0.4)]
    assert quality["full_course"] and quality["episodes"] == 50
    assert quality["values"][0] == pytest.approx(math.log(0.04))
    few = _cell("bee", "depth_noise", 0.8, 97, n=100, error=0.3)  # 3 successes: too few
    assert not cell_quality(few)[("depth_noise", 0.8)]["full_course"]
    assert cell_quality(_cell("bee", "forward_speed", 2.0, 50)) == {}  # a task factor has no dose


def test_p_values_are_floored() -> None:
    assert format_p(3e-12) == "< 1e-06" and format_p(0.0123) == "0.012" and format_p(float("nan")) == "–"


def test_the_outlier_share_joins_the_fit_where_every_episode_recorded_it() -> None:
    def law(error: float, points: float, share: float) -> float:
        return 1.0 / (1.0 + math.exp(-(-3.0 + 8.0 * share)))

    rows = _law_cells(law, np.random.default_rng(2), outliers=True)
    fit = fit_dose_response(rows, cell_quality(rows))
    assert fit["features"] == ("log_depth_error", "valid_points_per_100", "outlier_share")
    low, high = fit["conf_int"]["outlier_share"]
    assert low < 8.0 < high
    # One episode from a file written before the outlier share existed: the fit falls back to two features.
    rows[0]["mean_depth_outlier_share"] = None
    assert fit_dose_response(rows, cell_quality(rows))["features"] == (
        "log_depth_error",
        "valid_points_per_100",
    )


def test_a_fit_needs_both_outcomes_and_spread() -> None:
    rows = _cell("bee", "clean", 0.0, 0)
    with pytest.raises(
        ValueError, match="needs >= 20 episodes with a depth error and both outcomes, got 100"
    ):
        fit_dose_response(rows, cell_quality(rows))
    rows = _cell("bee", "clean", 0.0, 50)
    with pytest.raises(
        ValueError, match="needs spread in every feature; log_depth_error, valid_points_per_100"
    ):
        fit_dose_response(rows, cell_quality(rows))


def test_breaking_points_are_measured_against_the_baseline_clean_table() -> None:
    rows = _sweep()
    baseline = _cell("bee", "clean", 0.0, 30, n=300)  # 0.10 on 300 layouts, against the sweep's 0.20
    table = {(r["factor"], r["side"]): r for r in tolerance_table(rows, baseline)}
    row = table[("rotation_error", "above")]
    assert row["clean_failure"] == pytest.approx(0.10) and row["clean_episodes"] == 300
    assert row["clean_source"] == "the 300-layout clean table"
    assert row["breaking_level"] == 0.05  # 0.22 is above the baseline's interval, not the sweep cell's
    assert {(r["factor"], r["side"]): r for r in tolerance_table(rows)}[("rotation_error", "above")][
        "breaking_level"
    ] == 0.5
    assert tolerance_table(rows)[0]["clean_source"] == "the sweep's clean cell"


def test_a_learned_agents_interval_spans_its_training_runs() -> None:
    from agents.analysis.statistics import failure_interval

    agree = [{"run": f"a@{k}", "success": i >= 5} for k in range(5) for i in range(20)]
    differ = [{"run": f"a@{k}", "success": i >= (0, 0, 5, 10, 10)[k]} for k in range(5) for i in range(20)]
    low, high = failure_interval(agree)
    spread_low, spread_high = failure_interval(differ)
    assert sum(not r["success"] for r in differ) == sum(not r["success"] for r in agree)  # both 0.25
    assert spread_high - spread_low > high - low


def test_the_report_and_figure_are_written(tmp_path: Path) -> None:
    rows = _sweep()
    rng = np.random.default_rng(1)
    for row in rows:
        cell_error = 0.03 + (0.2 * row["level"] if row["factor"] == "rotation_error" else 0.0)
        row["median_depth_error"] = cell_error * float(rng.uniform(0.9, 1.1))
        row["mean_points_valid"] = float(rng.uniform(50, 200))
    lines = write_error_analysis(rows, tmp_path, "flownav error-analysis --episodes x.csv")
    text = (tmp_path / "error_analysis.md").read_text()
    assert text == "\n".join(lines) + "\n"
    assert "| bee | rotation_error | above | 0.20 [0.13, 0.29] |" in text
    assert "| rotation_error | above | **0.5** (0.45, +0.25) |" in text
    assert "| forward_speed | below | — (0.18 at 0.25) |" in text
    assert "log_depth_error" in text and (tmp_path / "dose_response.png").stat().st_size > 10_000
    assert "| outlier_share |" not in text  # these rows never recorded it
    assert "how much each agent turns" not in text  # nor path length and progress
    for row in rows:
        row["mean_depth_outlier_share"] = float(rng.uniform(0.0, 0.2))
    write_error_analysis(rows, tmp_path, "flownav error-analysis --episodes x.csv")
    assert "| outlier_share |" in (tmp_path / "error_analysis.md").read_text()


def test_the_command_refuses_a_missing_or_empty_file(tmp_path: Path, capsys) -> None:
    missing = tmp_path / "none.csv"
    assert main(["error-analysis", "--episodes", str(missing), "--out", str(tmp_path)]) == 2
    assert f"--episodes {missing}: no such file" in capsys.readouterr().err
    empty = tmp_path / "empty.csv"
    empty.write_text("")
    assert main(["error-analysis", "--episodes", str(empty), "--out", str(tmp_path)]) == 2
    assert "holds no readable episode" in capsys.readouterr().err


def test_rotation_error_is_set_beside_how_much_each_agent_weaves(tmp_path: Path) -> None:
    rows = []
    for agent, path, errors in (("vfh", 22.0, (0.06, 0.6)), ("bee", 20.2, (0.04, 0.05))):
        for factor, level, error in (("clean", 0.0, errors[0]), ("rotation_error", 1.0, errors[1])):
            for row in _cell(agent, factor, level, 5, n=10, error=error):
                rows.append({**row, "path_length_m": path, "progress_m": 20.0})
    rows.append({**rows[0], "agent": "bee", "progress_m": 0.5, "path_length_m": 9.0})  # crashed at the start
    table = turning_and_rotation_error(rows)
    assert [r["agent"] for r in table] == ["bee", "vfh"]
    assert table[0]["weaving"] == pytest.approx(0.01) and table[1]["weaving"] == pytest.approx(0.1)
    assert table[1]["depth_error"] == {0.0: pytest.approx(0.06), 1.0: pytest.approx(0.6)}
    write_error_analysis(rows, tmp_path, "flownav error-analysis")
    assert "| vfh | 10.0 % | 0.06 | 0.60 |" in (tmp_path / "error_analysis.md").read_text()
    assert (
        turning_and_rotation_error([{k: v for k, v in r.items() if k != "path_length_m"} for r in rows]) == []
    )


def _write_sweep_episodes(path: Path, separated: bool) -> None:
    import dataclasses

    from agents.analysis.records import append_record

    rng = np.random.default_rng(0)
    for factor, level in (
        ("clean", 0.0),
        ("rotation_error", 0.1),
        ("rotation_error", 0.3),
        ("rotation_error", 0.5),
        ("rotation_error", 1.0),
    ):
        cell_error = 0.02 + 0.3 * level
        for i in range(60):
            failed = level >= 0.5 if separated else bool(rng.random() < 0.1 + 0.6 * level)
            # A full-course flight of a flow agent: what the dose-response fits are over.
            record = dataclasses.replace(
                EPISODE,
                agent=f"ppo_flow@{i % 3}",
                factor=factor,
                level=level,
                seed=1_000_000 + i,
                collision=failed,
                success=not failed,
                progress_m=20.0,
                time_s=20.0,
                steps=200,
                min_clearance_m=0.5,
                path_length_m=20.4,
                mean_points_valid=float(rng.uniform(50, 200)),
                median_depth_error=cell_error * float(rng.uniform(0.9, 1.1)),
                episode_return=1.0,
                env_kwargs=json.dumps({"obs_source": "flow"}),
                mean_depth_outlier_share=float(rng.uniform(0.0, 0.2)),
            )
            append_record(path, record)


def test_the_command_pools_a_learned_agents_training_seeds(tmp_path: Path) -> None:
    episodes = tmp_path / "sweep_episodes.csv"
    _write_sweep_episodes(episodes, separated=False)
    assert main(["error-analysis", "--episodes", str(episodes), "--out", str(tmp_path)]) == 0
    text = (tmp_path / "error_analysis.md").read_text()
    assert "| ppo_flow@all | rotation_error | above |" in text and "ppo_flow@0" not in text
    assert "| ppo_flow@all | 300 | 60 | const |" in text  # one fit over all three seeds' episodes


def test_a_fit_that_separates_the_outcomes_is_refused_not_reported(tmp_path: Path) -> None:
    episodes = tmp_path / "sweep_episodes.csv"
    _write_sweep_episodes(episodes, separated=True)  # every episode with error > 0.2 fails, no other
    assert main(["error-analysis", "--episodes", str(episodes), "--out", str(tmp_path)]) == 0
    text = (tmp_path / "error_analysis.md").read_text()
    assert "- `ppo_flow@all`: no fit (the logistic fit on depth quality has no reliable estimate" in text
    assert "perfectly separated" in text and "| ppo_flow@all | 300 | 60 | const |" not in text


def test_what_does_not_break_the_best_learned_flow_agent_says_why() -> None:
    rows = _cell("ppo_flow@all", "clean", 0.0, 10) + _cell("ppo_robust@all", "clean", 0.0, 40)
    rows += _cell("ppo_oracle@all", "clean", 0.0, 2)  # true depths: never the best *flow* agent
    rows += _cell("ppo_flow@all", "brightness", 4.0, 12)  # the range's end, inside the clean interval
    rows += _cell("ppo_flow@all", "obstacle_density", 0.06, 1)  # easier
    rows += _cell("ppo_flow@all", "depth_noise", 0.2, 15)  # harder, but short of breaking
    rows += _cell("ppo_flow@all", "forward_speed", 2.0, 60)  # breaks
    table = tolerance_table(rows)
    assert best_learned_flow_agent(table) == "ppo_flow@all"
    values = report_values(rows)
    assert values.best == "ppo_flow@all"
    text = render_report(
        "error_analysis.md.j2",
        ErrorAnalysisValues(
            SweepSections(**vars(values), figure="f.png", clean_text="c"), 0, "today", "test"
        ),
    )
    reasons = {(r["factor"], r["side"]) for r in table if r["agent"] == "ppo_flow@all"}
    assert "- `brightness` (above): flown to the end of the setting's range [0.0, 4.0]" in text
    assert "- `obstacle_density` (below): this direction makes the task easier" in text
    assert (
        "- `depth_noise` (above): not broken up to 0.2 (worst 0.15 at 0.2), short of the range's end: more levels are needed."
        in text
    )
    # forward_speed breaks it, so it is not listed
    assert {(r["factor"], r["side"]) for r in values.unbroken} == set(reasons) - {("forward_speed", "above")}


def test_the_clean_baseline_holds_only_the_training_runs_the_sweep_flew(tmp_path: Path) -> None:
    import dataclasses

    from agents.analysis.records import append_record, read_records
    from agents.reports.error_analysis_report import write_error_analysis_from

    episodes = tmp_path / "sweep_episodes.csv"
    _write_sweep_episodes(episodes, separated=False)
    baseline = tmp_path / "leaderboard_episodes.csv"
    clean = [row for row in read_records(episodes) if row["factor"] == "clean"]
    template = dataclasses.replace(EPISODE, env_kwargs="{}", factor="clean", level=0.0)
    for row in clean:  # the sweep's own clean runs, and a seed shipped later that fails every layout
        append_record(
            baseline,
            dataclasses.replace(
                template,
                agent=row["agent"],
                seed=row["seed"],
                success=row["success"],
                collision=not row["success"],
            ),
        )
        append_record(
            baseline, dataclasses.replace(template, agent="ppo_flow@3", seed=row["seed"], success=False)
        )
    write_error_analysis_from([episodes], tmp_path, "flownav error-analysis", baseline)
    rate = sum(not row["success"] for row in clean) / len(clean)
    text = (tmp_path / "error_analysis.md").read_text()
    assert f"| clean failure |  | {rate:.2f} [" in text and f"], {len(clean)} episodes |" in text
