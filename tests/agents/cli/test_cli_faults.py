"""What a new user and a fault run hit at the command line: unwritable outputs refused before any work, write
errors in one line, defaults that read the repository's inputs from any folder and write to scratch."""

from __future__ import annotations

import argparse
import errno
import os
from pathlib import Path

import pytest

from agents import cli
from agents.common.locations import REPO_ROOT, RESULTS_DIR


def unwritable_folder() -> Path:
    """A folder no process may write to, even root: sysfs refuses new files."""
    folder = Path("/sys/flownav_test_output")
    try:
        folder.mkdir()
    except OSError:
        return folder
    folder.rmdir()
    pytest.skip("no unwritable folder on this machine")


def test_evaluate_refuses_an_unwritable_out_before_flying(
    capsys: pytest.CaptureFixture[str], monkeypatch
) -> None:
    def fly(*_args, **_kwargs):
        raise AssertionError("an episode was flown before the output folder was checked")

    monkeypatch.setattr("agents.evaluation.runner.run_task", fly)
    out = unwritable_folder() / "episodes.csv"
    code = cli.main(["evaluate", "--agent", "straight", "--layouts", "1", "--out", str(out)])
    error = capsys.readouterr().err.strip()
    assert code == 2
    assert error.startswith(
        "flownav evaluate: error: cannot write to the output folder /sys/flownav_test_output"
    )
    assert len(error.splitlines()) == 1


def test_sweep_refuses_an_unwritable_out_before_flying(capsys: pytest.CaptureFixture[str]) -> None:
    code = cli.main(["sweep", "--layouts", "1", "--out", str(unwritable_folder())])
    assert code == 2
    assert "cannot write to the output folder /sys/flownav_test_output" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("error", "line"),
    [
        (
            OSError(errno.ENOSPC, "No space left on device", "runs/x.csv"),
            "No space left on device: runs/x.csv",
        ),
        (OSError(errno.EFBIG, "File too large", "runs/big.npz"), "File too large: runs/big.npz"),
        (OSError(errno.EROFS, "Read-only file system"), "Read-only file system"),
    ],
)
def test_a_write_error_is_one_line_naming_the_file_and_exit_1(
    error: OSError, line: str, capsys: pytest.CaptureFixture[str], monkeypatch
) -> None:
    def fail(_args: argparse.Namespace) -> int:
        raise error

    monkeypatch.setattr("agents.cli.curves.run", fail)  # build_parser takes each command's run by name
    code = cli.main(["curves", "a.npz"])
    assert code == 1
    assert capsys.readouterr().err == f"flownav curves: error: {line}\n"


def test_leaderboard_refuses_too_few_layouts_before_flying(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    code = cli.main(["leaderboard", "--agents", "straight", "--layouts", "3", "--out", str(tmp_path)])
    assert code == 2
    assert "--layouts must be >= 30 (one block of layouts for the intervals over runs), got 3" in (
        capsys.readouterr().err
    )
    assert not (tmp_path / "leaderboard_episodes.csv").exists()


def test_a_config_path_that_is_a_directory_says_so(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    code = cli.main(["sweep", "--config", str(tmp_path), "--out", str(tmp_path / "out")])
    assert code == 2
    assert f"config {tmp_path} is a directory: give the path of a YAML file" in capsys.readouterr().err


def test_defaults_that_read_committed_inputs_resolve_against_the_repository(
    tmp_path: Path, monkeypatch
) -> None:
    monkeypatch.chdir(tmp_path)
    parser = cli.build_parser()
    sweep = parser.parse_args(["sweep"])
    assert Path(sweep.config) == REPO_ROOT / "configs" / "sweep.yaml" and Path(sweep.config).is_file()
    from agents.cli.error_analysis import episode_files

    (episodes,) = episode_files(parser.parse_args(["error-analysis"]))
    assert episodes == RESULTS_DIR / "sweep_episodes.csv" and episodes.is_file()


def test_no_command_writes_into_results_unless_out_names_it() -> None:
    parser = cli.build_parser()
    commands = parser._subparsers._group_actions[0].choices
    checked = 0
    for name, command in commands.items():
        for subparser in [command, *_nested(command)]:
            for action in subparser._actions:
                if action.dest != "out" or action.default is None:
                    continue
                checked += 1
                default = Path(os.path.abspath(action.default))
                assert not default.is_relative_to(RESULTS_DIR), f"flownav {name} --out defaults to {default}"
                assert Path(action.default).parts[0] == "runs", (
                    f"flownav {name} --out defaults to {action.default}"
                )
    assert checked >= 8


def _nested(parser: argparse.ArgumentParser) -> list[argparse.ArgumentParser]:
    return [
        sub for action in parser._actions if isinstance(action, argparse._SubParsersAction)
        for sub in action.choices.values()
    ]  # fmt: skip


def test_evaluate_unpickles_a_bare_policy_zip_only_with_trust_pickle(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import shutil

    from agents.analysis.records import read_records

    bare = tmp_path / "bare.zip"  # no training config beside it: only PPO.load (unpickling) can read it
    shutil.copy(RESULTS_DIR / "policies" / "ppo_flow" / "seed_0.zip", bare)
    out = tmp_path / "episodes.csv"
    command = ["evaluate", "--agent", "ppo_flow", "--policy", str(bare), "--layouts", "1", "--out", str(out)]
    assert cli.main(command) == 2
    error = capsys.readouterr().err
    assert "has no training config beside it" in error and "--trust-pickle" in error
    assert not out.exists() or not read_records(out)
    assert (
        cli.main([*command, "--trust-pickle", "--env", "camera_width=96", "--env", "camera_height=72"]) == 0
    )
    assert len(read_records(out)) == 1
