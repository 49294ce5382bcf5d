"""The decision log: its choices parse, each names a commit of the history, and the committed page is what the
code reads from the history now (where the checkout has its history)."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from agents.common.locations import REPO_ROOT, RESULTS_DIR
from agents.studies.decision_log import (
    PAGE,
    commit_of,
    read_decisions,
    version_rows,
    write_decision_log,
)


def _has_history() -> bool:
    result = subprocess.run(
        ["git", "-C", str(REPO_ROOT), "cat-file", "-e", f"{read_decisions()[1]}^{{commit}}"],
        capture_output=True,
        check=False,
    )
    return result.returncode == 0


needs_history = pytest.mark.skipif(not _has_history(), reason="a checkout without the history the log reads")


def test_the_log_names_its_version_and_choices() -> None:
    version, frozen_at, decisions = read_decisions()
    assert version == "2" and frozen_at and decisions
    assert len({decision.id for decision in decisions}) == len(decisions)


@needs_history
def test_every_choice_names_a_commit_of_the_history() -> None:
    for decision in read_decisions()[2]:
        found = subprocess.run(
            ["git", "-C", str(REPO_ROOT), "cat-file", "-e", f"{decision.commit}^{{commit}}"],
            capture_output=True,
            check=False,
        )
        assert found.returncode == 0, f"{decision.id}: {decision.commit} is no commit of this repository"


@needs_history
def test_the_committed_page_is_what_the_history_gives(tmp_path: Path) -> None:
    written = write_decision_log(tmp_path, "flownav decision-log --out results")
    table = [line for line in written.read_text().splitlines() if line.startswith("|")]
    committed = [line for line in (RESULTS_DIR / PAGE).read_text().splitlines() if line.startswith("|")]
    assert table == committed  # on a difference: flownav decision-log --out results


def test_a_choice_without_its_keys_is_one_line(tmp_path: Path) -> None:
    path = tmp_path / "decisions.yaml"
    path.write_text("suite_version: '2'\nfrozen_at: abc\ndecisions:\n  - id: x\n    chose: y\n")
    with pytest.raises(ValueError, match=r"decisions.yaml: decision 'x' lacks commit, validation$"):
        read_decisions(path)


def test_rows_and_commits_are_read_from_an_episodes_file() -> None:
    text = "agent,suite_version,code_version\nppo_flow@3,2,commit `abc1234`\nbee,1,commit `def5678`\n"
    assert version_rows(text, "2") == [("ppo_flow", "commit `abc1234`")]
    assert commit_of("commit `abc1234` with uncommitted changes in agents/") == "abc1234"
    assert commit_of("unknown (not a git checkout)") == ""
