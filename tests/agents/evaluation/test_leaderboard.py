"""The leading table over training seeds: run names, per-run rates, interval estimates and the probability of
improvement, on synthetic episodes with known answers (no flying: the runner is tested elsewhere)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from agents.analysis.over_seeds import (
    block_scores,
    interval_estimates,
    probability_of_improvement,
    run_rates,
    success_outcomes,
)
from agents.analysis.statistics import runs_and_layouts_interval
from agents.evaluation.leaderboard import (
    against_best_reactive,
    improvements,
    leaderboard_runs,
    leaderboard_tasks,
    summarise_runs,
)
from agents.pages.leaderboard_page import report_lines
from agents.policies import (
    REACTIVE_AGENTS,
    is_learned,
    policy_file,
    seeded_agent_name,
    split_agent_name,
    trained_seeds,
)

LAYOUTS = list(range(1_000_000, 1_000_040))


def _rows(agent: str, successes: list[bool]) -> list[dict]:
    return [
        {
            "agent": agent,
            "factor": "clean",
            "level": 0.0,
            "seed": seed,
            "success": ok,
            "collision": not ok and seed % 2 == 0,
            "out_of_bounds": not ok and seed % 2 == 1,
        }
        for seed, ok in zip(LAYOUTS, successes, strict=True)
    ]


def _synthetic() -> tuple[list[dict], dict[str, list[str]]]:
    rng = np.random.default_rng(0)
    rows = _rows("bee", list(rng.random(len(LAYOUTS)) < 0.3))
    runs = {"bee": ["bee"], "ppo_flow": []}
    for seed, rate in enumerate((0.7, 0.8, 0.9)):
        name = seeded_agent_name("ppo_flow", seed)
        runs["ppo_flow"].append(name)
        rows += _rows(name, list(rng.random(len(LAYOUTS)) < rate))
    return rows, runs


def test_training_seed_names_round_trip_and_find_their_policy_files() -> None:
    assert seeded_agent_name("ppo_flow", 3) == "ppo_flow@3"
    assert split_agent_name("ppo_flow@3") == ("ppo_flow", 3)
    assert split_agent_name("bee") == ("bee", None)
    assert is_learned("ppo_oracle@0") and not is_learned("vfh")
    assert policy_file("ppo_flow@3", directory="pol") == Path("pol/ppo_flow/seed_3.zip")
    assert policy_file("ppo_flow", directory="pol") == Path("pol/ppo_flow.zip")


@pytest.mark.parametrize(
    ("name", "message"),
    [
        ("bee@1", "only learned agents have training seeds"),
        ("ppo_flow@x", "a training seed must be an integer >= 0, got 'ppo_flow@x'"),
        ("ppo_flow@-1", "a training seed must be an integer >= 0"),
        ("hawk", "agent must be one of straight, bee"),
    ],
)
def test_bad_agent_names_are_refused_with_the_allowed_forms(name: str, message: str) -> None:
    with pytest.raises(ValueError, match="^" + message.replace("(", r"\(").replace(")", r"\)")):
        split_agent_name(name)


def test_runs_are_the_shipped_seeds_and_every_run_flies_the_same_layouts(tmp_path: Path, capsys) -> None:
    (tmp_path / "ppo_flow").mkdir()
    for seed in (2, 0, 11):
        (tmp_path / "ppo_flow" / f"seed_{seed}.zip").write_bytes(b"")
    (tmp_path / "ppo_flow" / "seed_x.zip").write_bytes(b"")
    assert trained_seeds("ppo_flow", tmp_path) == [0, 2, 11]
    runs = leaderboard_runs(["bee", "ppo_flow", "ppo_oracle"], tmp_path)
    assert runs == {"bee": ["bee"], "ppo_flow": ["ppo_flow@0", "ppo_flow@2", "ppo_flow@11"]}
    assert "leaving out ppo_oracle" in capsys.readouterr().out
    tasks = leaderboard_tasks(runs, 3, tmp_path)
    assert len(tasks) == 12 and {t.seed for t in tasks} == {1_000_000, 1_000_001, 1_000_002}
    assert tasks[1].policy == str(tmp_path / "ppo_flow" / "seed_0.zip") and tasks[0].policy is None
    with pytest.raises(ValueError, match="agent must be one of straight"):
        leaderboard_runs(["ppo_flow@0"], tmp_path)


def test_per_run_rates_split_failures_into_their_causes() -> None:
    rows, _ = _synthetic()
    table = {(r["agent"], r["train_seed"]): r for r in run_rates(rows)}
    assert set(table) == {("bee", ""), ("ppo_flow", 0), ("ppo_flow", 1), ("ppo_flow", 2)}
    for r in table.values():
        assert r["episodes"] == len(LAYOUTS)
        assert r["failure_rate"] == pytest.approx(1 - r["success_rate"])
        assert r["failure_rate"] == pytest.approx(r["collision_rate"] + r["out_of_bounds_rate"])


def test_outcomes_need_every_run_on_every_layout() -> None:
    rows, runs = _synthetic()
    outcomes = success_outcomes(rows, runs["ppo_flow"], LAYOUTS)
    assert outcomes.shape == (3, 40)
    with pytest.raises(ValueError, match="run 'ppo_flow@0' has not flown layout 1000040"):
        success_outcomes(rows, runs["ppo_flow"], [*LAYOUTS, 1_000_040])
    assert block_scores(outcomes, 10).shape == (3, 4)
    with pytest.raises(ValueError, match="need at least one block of 50 layouts, got 40"):
        block_scores(outcomes, 50)


def test_interval_estimates_cover_the_truth_and_single_runs_have_none() -> None:
    rng = np.random.default_rng(1)
    outcomes = (rng.random((5, 300)) < 0.7).astype(float)
    estimates = interval_estimates({"x": block_scores(outcomes), "one": block_scores(outcomes[:1])}, reps=300)
    assert estimates["x"]["mean_low"] < outcomes.mean() < estimates["x"]["mean_high"]
    assert estimates["x"]["iqm_low"] <= estimates["x"]["iqm"] <= estimates["x"]["iqm_high"]
    assert estimates["one"]["mean_low"] == estimates["one"]["mean_high"]
    low, high = runs_and_layouts_interval(outcomes, reps=500)
    assert low < 0.7 < high and high - low < 0.15
    # Runs that disagree widen the interval beyond what the layouts alone give.
    spread = np.vstack([(rng.random((1, 300)) < p).astype(float) for p in (0.3, 0.5, 0.7, 0.9, 0.95)])
    spread_low, spread_high = runs_and_layouts_interval(spread, reps=500)
    assert spread_high - spread_low > 2 * (high - low)


def test_bootstrap_intervals_repeat_for_the_same_scores_and_leave_numpys_global_state_alone() -> None:
    # rliable's stratified bootstrap draws from np.random itself: unseeded, every report moved its intervals.
    rng = np.random.default_rng(2)
    x = block_scores((rng.random((5, 300)) < 0.7).astype(float))
    y = block_scores((rng.random((1, 300)) < 0.6).astype(float))
    np.random.seed(123)  # noqa: NPY002
    expected_next = np.random.random()  # noqa: NPY002
    np.random.seed(123)  # noqa: NPY002
    first = (interval_estimates({"x": x}, reps=200), probability_of_improvement(x, y, reps=100))
    assert np.random.random() == expected_next  # noqa: NPY002
    np.random.seed(7)  # noqa: NPY002  (another global state must not matter)
    assert (interval_estimates({"x": x}, reps=200), probability_of_improvement(x, y, reps=100)) == first
    assert interval_estimates({"x": x}, seed=1, reps=200) != first[0]


def test_probability_of_improvement_is_one_for_a_clear_winner_and_a_half_for_a_tie() -> None:
    better = np.full((3, 4), 0.9)
    worse = np.full((1, 4), 0.2)
    assert probability_of_improvement(better, worse, reps=50)[0] == pytest.approx(1.0)
    assert probability_of_improvement(worse, better, reps=50)[0] == pytest.approx(0.0)
    assert probability_of_improvement(worse, worse, reps=50)[0] == pytest.approx(0.5)


def test_the_report_leads_with_every_agent_and_compares_learned_with_reactive() -> None:
    rows, runs = _synthetic()
    table = summarise_runs(rows, runs, LAYOUTS, block=10)
    by_agent = {r["agent"]: r for r in table}
    assert by_agent["ppo_flow"]["runs"] == 3 and by_agent["ppo_flow"]["episodes"] == 120
    assert by_agent["bee"]["interval_over"] == "layouts (Wilson)"
    learned = by_agent["ppo_flow"]
    assert learned["failure_low"] <= learned["failure_rate"] <= learned["failure_high"]
    gains = improvements(rows, runs, LAYOUTS, block=10)
    assert [(g["learned"], g["reactive"]) for g in gains] == [("ppo_flow", "bee")]
    assert gains[0]["probability"] > 0.9
    against_best = against_best_reactive(table, rows, runs, LAYOUTS)
    assert [(c.agent, c.reference) for c in against_best] == [("ppo_flow", "bee")]
    assert against_best[0].fails_less == "ppo_flow"
    text = "\n".join(
        report_lines(
            table, gains, LAYOUTS, "flownav leaderboard --episodes 40", block=10, against_best=against_best
        )
    )
    assert "| ppo_flow | 3 | 120 |" in text and "| bee | 1 | 40 |" in text
    assert f"- `ppo_flow` − `bee` = {against_best[0].difference:+.3f} [" in text
    assert "`ppo_flow` fails less than `bee`" in text and "overlap" not in text


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (
            ["--layouts", "0"],
            "--layouts must be >= 30 (one block of layouts for the intervals over runs), got 0",
        ),
        (["--workers", "0"], "--workers must be >= 1, got 0"),
        (["--agents", "bee,hawk"], f"agent must be one of {', '.join(REACTIVE_AGENTS)}, ppo_flow"),
    ],
)
def test_the_command_refuses_bad_input_before_flying(
    tmp_path: Path, capsys, extra: list[str], message: str
) -> None:
    from agents.cli import main

    assert main(["leaderboard", "--out", str(tmp_path / "lb"), *extra]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "lb").exists()


def test_layouts_are_resampled_once_for_all_the_runs_that_flew_them() -> None:
    from agents.analysis.statistics import wilson_interval

    # Five runs that agree layout by layout know no more than one run does: a hard layout is hard for all.
    shared = (np.random.default_rng(3).random(300) < 0.7).astype(float)
    low, high = runs_and_layouts_interval(np.tile(shared, (5, 1)), reps=1000)
    one_low, one_high = wilson_interval(int(shared.sum()), 300)
    assert high - low > 0.8 * (one_high - one_low)
