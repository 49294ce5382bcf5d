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
        "--layouts",
        "1",
        "--tiers",
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

    assert main(["evaluate", "--agent", "bee", "--layouts", "0"]) == 2
    assert "flownav evaluate: error: --layouts must be >= 1, got 0" in capsys.readouterr().err


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

    args = ["evaluate", "--agent", "straight", "--layouts", "1", "--tiers", "FlowNav-v9"]
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


def test_demo_says_on_how_few_layouts_it_rests_and_where_the_full_table_is() -> None:
    from agents.cli.demo import demo_note
    from agents.common.locations import RESULTS_DIR

    note = demo_note(4, "clean", Path("runs/demo"))
    assert (
        "every agent on the first 4 frozen test layouts of the clean tier, ranked as the suite ranks" in note
    )
    assert (
        f"the leading table, every tier's 300 layouts, is {RESULTS_DIR / 'suite.md'} (flownav suite)" in note
    )
