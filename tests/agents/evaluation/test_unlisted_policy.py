"""A FlowNav agent scored with a policy file its folder's manifest does not list is refused, unless opted in, and
then its rows are named for the file, never as the published agent."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from agents.cli import main
from agents.common.locations import POLICIES_DIR
from agents.evaluation.suite_report import read_suite_csv

ONE_LAYOUT = ["--tiers", "clean", "--layouts", "1", "--workers", "1"]


@pytest.fixture
def unlisted(tmp_path: Path) -> Path:
    """A shipped policy and its config copied where no manifest lists them."""
    for suffix in (".zip", ".yaml"):
        shutil.copy(POLICIES_DIR / "ppo_flow" / f"seed_0{suffix}", tmp_path / f"mine{suffix}")
    return tmp_path / "mine.zip"


def test_an_unlisted_policy_is_refused_in_one_line(
    unlisted: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = [
        "score",
        "--agent",
        "ppo_flow",
        "--policy",
        str(unlisted),
        *ONE_LAYOUT,
        "--out",
        str(tmp_path / "o"),
    ]
    assert main(argv) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"flownav score: error: --policy: {unlisted} is not beside a MANIFEST.sha256")
    assert line.endswith(
        "its rows would stand under ppo_flow's name: pass --unlisted-policy to score it anyway, "
        "under a name that says so"
    )
    assert not (tmp_path / "o" / "suite_episodes.csv").exists()


def test_an_unlisted_policy_opted_in_is_named_for_its_file(unlisted: Path, tmp_path: Path) -> None:
    out = tmp_path / "o"
    argv = ["score", "--agent", "ppo_flow", "--policy", str(unlisted), *ONE_LAYOUT, "--out", str(out)]
    assert main([*argv, "--unlisted-policy"]) == 0
    (row,) = read_suite_csv(out / "score.csv")
    assert row["agent"] == "ppo_flow (mine.zip, unlisted)"
