"""``flownav verify``: honest rows pass (``verified k/k``, and ``--include`` marks them verified); a rate edited
in score.csv, or an episode's outcome edited in the episodes file (its checksum resealed, its rates made to
match), is named and exits 1."""

from __future__ import annotations

import csv
import io
import json
import shutil
from pathlib import Path

import pytest

from agents.analysis.csv_file import sealed_line
from agents.analysis.statistics import wilson_interval
from agents.cli import main
from agents.common.seeds import suite_seeds
from agents.common.signing import key_path
from agents.evaluation.suite_report import OUTCOMES
from agents.evaluation.verification_record import VERIFICATION_JSON, verification_mark
from agents.evaluation.verify import Verification

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "open_gap_agent.py"
AGENT = f"{EXAMPLE}:make_agent"
ONE_LAYOUT = ["--tiers", "clean", "--layouts", "1", "--workers", "1"]


@pytest.fixture(scope="module")
def scored(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A real score of the example agent on one layout of the clean tier."""
    out = tmp_path_factory.mktemp("scored") / "mine"
    assert main(["score", "--agent", AGENT, *ONE_LAYOUT, "--out", str(out)]) == 0
    return out


@pytest.fixture
def copy(scored: Path, tmp_path: Path) -> Path:
    """A copy of the scored folder this test may edit."""
    return Path(shutil.copytree(scored, tmp_path / "copy"))


def test_honest_rows_are_verified_and_included_as_verified(
    copy: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    score_csv = copy / "score.csv"
    assert verification_mark(score_csv) == "self-reported"
    assert main(["verify", str(score_csv), "--agent", AGENT]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith(
        "verified 1/1: each ends as the file says (a file with 2 % of its 1 episodes changed"
    )
    record = json.loads((copy / VERIFICATION_JSON).read_text())
    assert record["episodes_reflown"] == 1
    assert verification_mark(score_csv) == "verified (1 episodes re-flown)"
    score_csv.write_text(score_csv.read_text() + "\n")  # any change to the file: no longer what was verified
    assert verification_mark(score_csv) == "self-reported"


def _as_if(row: dict[str, str], ended: str) -> None:
    """``row`` (one layout) edited to say its episode ended ``ended``: a row the include checks accept."""
    for outcome in OUTCOMES:
        count = int(outcome == ended or (outcome == "failure" and ended != "success"))
        low, high = wilson_interval(count, 1)
        row.update(
            {
                f"{outcome}_rate": str(float(count)),
                f"{outcome}_low": f"{low:.4f}",
                f"{outcome}_high": f"{high:.4f}",
            }
        )


def test_a_rate_edited_in_score_csv_is_named(copy: Path, capsys: pytest.CaptureFixture[str]) -> None:
    score_csv = copy / "score.csv"
    rows = list(csv.DictReader(io.StringIO(score_csv.read_text())))
    true_rate = float(rows[0]["failure_rate"])
    _as_if(rows[0], "collision" if true_rate == 0.0 else "success")
    with score_csv.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]), lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
    assert main(["verify", str(score_csv), "--agent", AGENT]) == 1
    assert capsys.readouterr().out.splitlines() == [
        f"not verified: {score_csv}, tier clean: failure_rate is {1.0 - true_rate:g}, but its episodes give "
        f"{true_rate:g}"
    ]
    assert not (copy / VERIFICATION_JSON).exists()


def _flip_outcome(episodes_csv: Path) -> str:
    """Edit the one episode's outcome (success <-> collision) and reseal its checksum; returns what the file now
    says."""
    header, line = episodes_csv.read_text().splitlines()[:2]
    names = next(csv.reader([header]))
    row = dict(zip(names, next(csv.reader([line])), strict=True))
    was = "success" if row["success"] == "True" else "not success"
    row.update(success=str(was != "success"), collision=str(was == "success"), out_of_bounds="False")
    values = [row[name] for name in names[:-1]]
    episodes_csv.write_text(header + "\n" + sealed_line(values))
    return "collision" if was == "success" else "success"


def test_an_episode_edited_to_another_outcome_is_named(
    copy: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    said = _flip_outcome(copy / "suite_episodes.csv")
    # The rates made to match the edited episode: score flies nothing and rewrites score.csv from the file.
    assert main(["score", "--agent", AGENT, *ONE_LAYOUT, "--out", str(copy)]) == 0
    capsys.readouterr()
    assert main(["verify", str(copy / "score.csv"), "--agent", AGENT]) == 1
    (line,) = capsys.readouterr().out.splitlines()
    assert line.startswith(
        f"not verified: the episode of {AGENT} on tier clean, layout seed {suite_seeds(1)[0]}: the file says "
        f"{said}, flown again on the CPU it was flown on it ends in "
    )
    assert not line.endswith(said)


@pytest.mark.parametrize("sample", ["0", "-2"])
def test_a_bad_sample_is_one_line(copy: Path, sample: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["verify", str(copy / "score.csv"), "--agent", AGENT, "--sample", sample]) == 2
    assert capsys.readouterr().err.strip() == (
        f"flownav verify: error: --sample must be an integer >= 1, got {int(sample)}"
    )


def test_another_agents_file_is_refused(copy: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["verify", str(copy / "score.csv"), "--agent", "straight"]) == 2
    assert capsys.readouterr().err.strip() == (
        f"flownav verify: error: {copy / 'suite_episodes.csv'} holds no episodes of straight as it is now (same "
        "file hash, settings and layouts): is that the agent the rows are of?"
    )


def test_a_verification_line_says_what_was_checked() -> None:
    assert Verification(3, 3, total=300).line() == (
        "verified 3/3: each ends as the file says (a file with 2 % of its 300 episodes changed is caught 6 % of "
        "the time)"
    )
    assert Verification(1, 3, mismatch="x differs").line() == "not verified: x differs"
    statistically = Verification(4, 4, total=300, other_cpu=4, agreed_other_cpu=3, p_value=1.0).line()
    assert "4 of them statistically: the file flew them on another CPU" in statistically
    assert "3 of 4 end as the file says" in statistically


def test_a_verification_record_not_signed_with_this_users_key_is_self_reported(
    copy: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    score_csv = copy / "score.csv"
    assert main(["verify", str(score_csv), "--agent", AGENT]) == 0
    signed = json.loads((copy / VERIFICATION_JSON).read_text())
    by_hand = {**signed, "episodes_reflown": 40}  # the hashes right, the signature now wrong
    (copy / VERIFICATION_JSON).write_text(json.dumps(by_hand))
    assert verification_mark(score_csv) == "self-reported"
    unsigned = {key: value for key, value in signed.items() if key != "signature"}
    (copy / VERIFICATION_JSON).write_text(json.dumps(unsigned))
    assert verification_mark(score_csv) == "self-reported"
    (copy / VERIFICATION_JSON).write_text(json.dumps(signed))
    assert verification_mark(score_csv) == "verified (1 episodes re-flown)"
    key_path().write_bytes(b"another user's key, 32 bytes....")  # the same record under another key
    assert verification_mark(score_csv) == "self-reported"


def test_episodes_flown_on_another_cpu_are_compared_statistically(
    copy: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    episodes_csv = copy / "suite_episodes.csv"
    header, line = episodes_csv.read_text().splitlines()[:2]
    names = next(csv.reader([header]))
    row = dict(zip(names, next(csv.reader([line])), strict=True))
    row["cpu"] = "GenuineIntel x86_64 a CPU this is not"
    episodes_csv.write_text(header + "\n" + sealed_line([row[name] for name in names[:-1]]))
    assert main(["verify", str(copy / "score.csv"), "--agent", AGENT]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("verified 1/1, 1 of them statistically: the file flew them on another CPU")
    assert verification_mark(copy / "score.csv") == (
        "verified (1 episodes re-flown, 1 of them on another CPU, compared statistically)"
    )
