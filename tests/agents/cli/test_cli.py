"""The flownav command line: every help page, one-line errors, commands end to end."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import flownav_env  # noqa: F401
from agents.cli import COMMANDS


def test_evaluate_command_prints_the_table(tmp_path: Path, capsys) -> None:
    from agents.cli import main

    args = [
        "evaluate",
        "--agent",
        "bee",
        "--episodes",
        "1",
        "--env-id",
        "FlowNavSingle-v0",
        "--env",
        "camera_width=96",
        "--env",
        "camera_height=72",
        "--out",
        str(tmp_path / "e.csv"),
    ]
    assert main(args) == 0
    assert "| bee |" in capsys.readouterr().out


def test_cli_reports_bad_input_in_one_line(capsys) -> None:
    from agents.cli import main

    assert main(["evaluate", "--agent", "bee", "--episodes", "0"]) == 2
    assert "flownav evaluate: error: --episodes must be >= 1, got 0" in capsys.readouterr().err


@pytest.mark.parametrize("command", [[], *[[name] for name in COMMANDS]])
def test_every_help_page_renders(command: list[str], capsys) -> None:
    # argparse %-formats help strings: a bare "%" in one crashes `flownav --help` itself.
    from agents.cli import main

    with pytest.raises(SystemExit) as exit_info:
        main([*command, "--help"])
    assert exit_info.value.code == 0
    assert "usage: flownav" in capsys.readouterr().out


def test_curves_command_plots_every_run_and_rejects_missing_files(tmp_path: Path, capsys) -> None:
    from agents.cli import main
    from agents.training.curves import run_label

    for name, scale in (("ppo_a", 1.0), ("ppo_b", 2.0)):
        np.savez(
            tmp_path / f"{name}_evaluations.npz",
            timesteps=np.array([100, 200, 300]),
            results=scale * np.arange(6.0).reshape(3, 2),
            ep_lengths=np.full((3, 2), 200),
        )
    out = tmp_path / "curves.png"
    files = [str(tmp_path / "ppo_a_evaluations.npz"), str(tmp_path / "ppo_b_evaluations.npz")]
    assert main(["curves", *files, "--out", str(out)]) == 0
    assert out.stat().st_size > 10_000
    assert run_label(Path("runs/ppo_x/evaluations.npz")) == "ppo_x"
    assert main(["curves", str(tmp_path / "none.npz"), "--out", str(out)]) == 2
    assert "evaluations file not found" in capsys.readouterr().err
    damaged = tmp_path / "ppo_c_evaluations.npz"
    damaged.write_bytes((tmp_path / "ppo_a_evaluations.npz").read_bytes()[:100])
    assert main(["curves", files[0], str(damaged), "--out", str(out)]) == 2
    error = capsys.readouterr().err
    assert f"evaluations file {damaged} is unreadable: " in error and error.count("\n") == 1


def test_grouped_curves_draw_a_panel_per_config_even_when_a_seed_stopped_evaluating_earlier(
    tmp_path: Path,
) -> None:
    from agents.training.curves import plot_grouped_learning_curves

    def evaluations(name: str, evaluations_done: int) -> Path:
        path = tmp_path / f"{name}.npz"
        steps = np.arange(1, evaluations_done + 1) * 100
        lengths = np.full((len(steps), 2), 200)
        np.savez(path, timesteps=steps, results=np.outer(steps, [1.0, 2.0]) / 100, ep_lengths=lengths)
        return path

    groups = {
        "ppo_a": {"seed 0": evaluations("a0", 3), "seed 1": evaluations("a1", 2)},
        "ppo_b": {"seed 0": evaluations("b0", 3)},
    }
    out = tmp_path / "grouped.png"
    plot_grouped_learning_curves(groups, out, "per config")
    assert out.stat().st_size > 10_000
    with pytest.raises(ValueError, match="no learning curves to plot: groups is empty"):
        plot_grouped_learning_curves({}, tmp_path / "none.png")


def test_an_unknown_env_id_is_one_line_naming_the_ids(tmp_path: Path, capsys) -> None:
    from agents.cli import main

    args = ["evaluate", "--agent", "straight", "--episodes", "1", "--env-id", "FlowNav-v9"]
    assert main([*args, "--out", str(tmp_path / "e.csv")]) == 2
    error = capsys.readouterr().err
    last_line = error.strip().splitlines()[-1]
    assert last_line.startswith("flownav evaluate: error: ") and "FlowNav-v0, FlowNavCorridor-v0" in last_line
    assert "Traceback" not in error


def test_ctrl_c_is_one_line_and_exit_130(monkeypatch, capsys) -> None:
    from agents.cli import main, tune

    def interrupted(args) -> int:
        raise KeyboardInterrupt("3 episodes are in x.csv; run the same command again to resume")

    monkeypatch.setattr(tune, "run", interrupted)
    assert main(["tune", "--agent", "bee"]) == 130
    assert "flownav tune: interrupted: 3 episodes are in x.csv" in capsys.readouterr().err


def test_version_and_scratch_defaults_of_report_writers(capsys) -> None:
    from agents import __version__
    from agents.cli import build_parser, main

    with pytest.raises(SystemExit):
        main(["--version"])
    assert capsys.readouterr().out.strip() == f"flownav {__version__}"
    parser = build_parser()
    # Reports land in results/ only when asked: a plain run must not replace the committed ones.
    assert parser.parse_args(["bench", "env"]).out == Path("runs/bench")
    assert parser.parse_args(["bench", "estimator"]).out == Path("runs/bench")
    assert parser.parse_args(["replicate"]).out == Path("runs/thesis")


def test_demo_says_how_few_episodes_it_flew_and_where_the_full_table_is(monkeypatch, capsys) -> None:
    # The runner is replaced by one that writes made-up records: the table's shape is under test, not flying.
    from agents.analysis.records import append_record
    from agents.cli import main
    from agents.common.locations import RESULTS_DIR
    from agents.evaluation import runner
    from agents.evaluation.episode import EpisodeRecord

    def made_up(tasks, csv_path, **kwargs) -> int:
        for task in tasks:
            success = task.agent != "straight"
            fields = dict.fromkeys(("time_s", "path_length_m", "mean_points_valid", "episode_return"), 1.0)
            record = EpisodeRecord(
                agent=task.agent, factor=task.factor, level=task.level, seed=task.seed, collision=not success,
                success=success, out_of_bounds=False, truncated=False, progress_m=30.0, steps=10,
                min_clearance_m=0.5, median_depth_error=0.1, **fields,
            )  # fmt: skip
            append_record(csv_path, record)
        return len(tasks)

    monkeypatch.setattr(runner, "execute", made_up)
    assert main(["demo", "--episodes", "5"]) == 0
    out = capsys.readouterr().out
    assert (
        "Only 5 episodes per agent: a quick look, not a ranking (the widest 95 % interval below spans 0.43)"
        in out
    )
    assert (
        "The leading table, every agent on each of the 4 tiers' 300 frozen test layouts (seeds from 2,000,000) and "
        f"learned agents over all their training seeds, is {RESULTS_DIR / 'suite.md'} (flownav suite)" in out
    )
    assert f"the clean tier's history table, {RESULTS_DIR / 'leaderboard.md'}, whose other layouts" in out
    table = [line for line in out.splitlines() if line.startswith("|")]
    assert table[0].startswith("| agent | episodes | failure rate [95 % CI] |")  # no constant factor, level
    assert any(line.startswith("| ppo_flow | 5 | 0.00 [0.00, 0.43] |") for line in table)  # seeds pooled
    from agents.policies import LEARNED_AGENTS, REACTIVE_AGENTS, default_runs

    flown = [*REACTIVE_AGENTS, *(agent for agent in LEARNED_AGENTS if default_runs(agent)[0])]
    assert len(table) == 2 + len(flown) and "clean" not in out.split("| agent |")[1]


def test_demo_keeps_factor_and_level_columns_that_differ() -> None:
    from agents.analysis.statistics import summarise
    from agents.cli.demo import demo_report

    rows = [
        {"agent": "bee", "factor": factor, "level": level, "seed": seed, "collision": False, "success": True}
        | {"out_of_bounds": False, "progress_m": 30.0, "min_clearance_m": 0.5}
        for factor, level in (("clean", 0.0), ("brightness", 0.5))
        for seed in range(2)
    ]
    report = demo_report(summarise(rows), "FlowNav-v0", 2)
    assert "| agent | factor | level | episodes |" in report and "| bee | brightness | 0.5 | 2 |" in report
    assert "Only 2 episodes per agent" in report
