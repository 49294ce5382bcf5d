"""Which layouts flownav evaluate may fly: validation (to decide on) or test (to report), never training, and
never a run that spans the two."""

from __future__ import annotations

import pytest

from agents.cli import main
from agents.cli.evaluate import check_evaluation_seeds
from agents.common.seeds import TEST_SEED_START, VALIDATION_SEED_START


def test_validation_and_test_runs_pass() -> None:
    check_evaluation_seeds(VALIDATION_SEED_START, 100)
    check_evaluation_seeds(TEST_SEED_START - 100, 100)
    check_evaluation_seeds(TEST_SEED_START, 300)


@pytest.mark.parametrize(
    ("start", "episodes", "message"),
    [
        (12, 5, f"--seed-start must be >= {VALIDATION_SEED_START} (training uses the seeds below), got 12"),
        (
            TEST_SEED_START - 10,
            20,
            f"seeds {TEST_SEED_START - 10}-{TEST_SEED_START + 9} span validation and test layouts",
        ),
    ],
)
def test_training_seeds_and_runs_across_the_boundary_are_one_line(
    start: int, episodes: int, message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(["evaluate", "--agent", "straight", "--layouts", str(episodes), "--seed-start", str(start)])
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1
