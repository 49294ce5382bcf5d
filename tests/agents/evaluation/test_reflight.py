"""``flownav reflight``: a published suite episode flown again comes out as its row says, and the file keeps each
CPU's re-flights once."""

from __future__ import annotations

from pathlib import Path

import pytest

from agents.analysis.reflights import Reflight, read_reflights, summarise_reflights, write_reflights
from agents.cli import main
from agents.common.locations import RESULTS_DIR
from agents.common.machine import cpu_signature
from agents.evaluation.reflight import pick_episodes, reflight
from agents.evaluation.suite import EPISODES_CSV


def test_a_published_rule_episode_re_flies_with_its_outcome() -> None:
    chosen = pick_episodes("bee_robust", ["clean"], 1, RESULTS_DIR / EPISODES_CSV, seed=0)
    (found,) = reflight(chosen, "bee_robust")
    assert found.same_outcome and found.cpu == cpu_signature() and found.tier == "clean"
    assert set(filter(None, found.differs.split(","))) <= {
        "path_length_m"
    }  # measured otherwise before, if at all


def _row(seed: int, cpu: str, differs: str = "") -> Reflight:
    return Reflight("bee_ttc", "bee_ttc", "hard", seed, cpu, "commit `abc1234`", differs, True)


def test_the_file_keeps_each_cpus_reflight_of_an_episode_once(tmp_path: Path) -> None:
    path = tmp_path / "suite_reflight.csv"
    write_reflights(path, [_row(1, "A"), _row(2, "A", "path_length_m")])
    write_reflights(path, [_row(1, "A", "progress_m"), _row(1, "B")])  # again on A replaces; B is added
    rows = read_reflights(path)
    assert len(rows) == 3 and _row(1, "A", "progress_m") in rows
    summaries = {summary.cpu: summary for summary in summarise_reflights(rows)}
    assert (summaries["A"].flown, summaries["A"].identical) == (2, 0)
    assert summaries["A"].differed == "progress_m: 1, path_length_m: 1"
    assert summaries["A"].code_versions == "abc1234"


def test_a_bad_episode_count_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["reflight", "--episodes", "0"]) == 2
    assert capsys.readouterr().err.strip() == "flownav reflight: error: --episodes must be >= 1, got 0"
