"""Any agent's robustness curves: the sweep's sensor factors, each curve's area and breaking level, end to end."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from agents.analysis.dose_response import TASK_FACTORS
from agents.analysis.records import read_records
from agents.cli import main
from agents.common.yaml_config import load_config
from agents.evaluation.sweep import SweepConfig
from agents.studies.robustness import SWEEP_CONFIG, curve_area, sensor_levels, summarise_curves, summary_lines

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "open_gap_agent.py"


def _rows(agent: str, factor: str, level: float, failures: int, episodes: int = 60) -> list[dict]:
    return [
        {
            "agent": agent,
            "factor": factor,
            "level": level,
            "seed": 1_000_000 + i,
            "success": i >= failures,
            "collision": i < failures,
            "out_of_bounds": False,
            "progress_m": 20.0,
            "min_clearance_m": 0.5,
        }
        for i in range(episodes)
    ]


def test_the_curves_are_the_sweeps_sensor_factors_or_a_subset_of_them() -> None:
    config = load_config(SWEEP_CONFIG, SweepConfig)
    every = sensor_levels(config)
    assert not set(every) & set(TASK_FACTORS) and "rotation_bias" in every
    assert every["rotation_bias"] == config.factors["rotation_bias"]
    assert list(sensor_levels(config, "depth_dropout,rotation_bias")) == ["rotation_bias", "depth_dropout"]
    with pytest.raises(
        ValueError, match=r"^--factors: 'forward_speed' is not one of the sweep's sensor factors \("
    ):
        sensor_levels(config, "forward_speed")
    with pytest.raises(ValueError, match=r"^--factors: give at least one of "):
        sensor_levels(config, " , ")


@pytest.mark.parametrize(
    ("points", "area"),
    [
        ([(0.0, 0.0), (1.0, 1.0)], 0.5),
        ([(1.0, 0.2), (0.0, 0.2), (0.5, 0.2)], 0.2),
        ([(0.0, 0.0), (0.1, 0.0), (1.0, 0.9)], 0.405),
        ([(0.3, 0.7)], 0.7),
    ],
)
def test_a_curves_area_is_its_mean_failure_over_the_flown_range(points, area: float) -> None:
    assert curve_area(points) == pytest.approx(area)


def test_each_side_of_a_curve_gets_its_area_and_breaking_level() -> None:
    from agents.analysis.statistics import summarise

    rows = _rows("mine", "clean", 0.0, 6)
    rows += _rows("mine", "rotation_bias", -0.3, 6) + _rows("mine", "rotation_bias", 0.3, 48)
    summary = {entry["side"]: entry for entry in summarise_curves(summarise(rows), rows)}
    above, below = summary["above"], summary["below"]
    assert above["breaking_level"] == 0.3 and above["breaking_failure"] == pytest.approx(0.8)
    assert above["area"] == pytest.approx((0.1 + 0.8) / 2) and above["levels"] == 1
    assert below["breaking_level"] is None and below["area"] == pytest.approx(0.1)


def test_an_outside_agents_curves_are_flown_resumed_and_summarised(tmp_path: Path, capsys) -> None:
    out = tmp_path / "score"
    argv = [
        "score", "--agent", f"{EXAMPLE}:make_agent", "--tiers", "clean", "--layouts", "1", "--robustness",
        "--factors", "translation_drift", "--robustness-layouts", "1", "--workers", "1", "--out", str(out),
    ]  # fmt: skip
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "| translation_drift | above |" in printed and "robustness curves written to" in printed
    with (out / "robustness.csv").open() as handle:
        curve = list(csv.DictReader(handle))
    assert [(row["factor"], float(row["level"])) for row in curve] == [
        ("clean", 0.0),
        ("translation_drift", 0.1),
        ("translation_drift", 0.3),
    ]
    with (out / "robustness_summary.csv").open() as handle:
        (summary,) = list(csv.DictReader(handle))
    assert (
        summary["factor"] == "translation_drift" and summary["side"] == "above" and summary["levels"] == "2"
    )
    assert (out / "robustness.png").stat().st_size > 0
    assert len(read_records(out / "robustness_episodes.csv")) == 3
    # The curves fly under the command's own limits, the sandbox included.
    assert {row["isolation"] for row in read_records(out / "robustness_episodes.csv")} == {"sandbox"}
    assert main(argv) == 0  # again: resumes and flies nothing
    assert len(read_records(out / "robustness_episodes.csv")) == 3


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--factors", "depth_noise"], "--factors and --robustness-layouts go with --robustness"),
        (["--robustness", "--robustness-layouts", "0"], "--robustness-layouts must be in [1, 100], got 0"),
    ],
)
def test_bad_robustness_input_is_one_line(argv: list[str], message: str, tmp_path: Path, capsys) -> None:
    base = ["score", "--agent", "straight", "--tiers", "clean", "--layouts", "1", "--workers", "1"]
    assert main([*base, *argv, "--out", str(tmp_path)]) == 2
    error = capsys.readouterr().err
    assert message in error and error.count("\n") == 1


def test_the_summary_table_has_a_row_per_curve_and_a_dash_where_nothing_breaks() -> None:
    curve = {"agent": "bee", "factor": "depth_noise", "side": "above", "area": 0.25, "clean_failure": 0.1}
    broken = {
        **curve,
        "breaking_level": 0.4,
        "breaking_failure": 0.5,
        "worst_level": 0.8,
        "worst_failure": 0.7,
    }
    unbroken = {
        **curve,
        "breaking_level": None,
        "breaking_failure": None,
        "worst_level": 0.8,
        "worst_failure": 0.2,
    }
    table = summary_lines([broken, unbroken])[0].splitlines()
    assert table[2] == "| `bee` | depth_noise | above | 0.25 | 0.10 | 0.4 | 0.50 | 0.8 (0.70) |"
    assert table[3] == "| `bee` | depth_noise | above | 0.25 | 0.10 | — | — | 0.8 (0.20) |"
