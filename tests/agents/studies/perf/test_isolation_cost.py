"""``flownav bench isolation``: the same agent timed in blocks alternately in process and in its own process,
their ratio per repeat; bad counts refused in one line."""

from __future__ import annotations

from pathlib import Path

import pytest

from agents.cli import main
from agents.studies.perf.isolation_cost import measure_isolation_cost


def test_each_repeat_times_every_side_and_its_ratio() -> None:
    rows = measure_isolation_cost(steps=3, repeats=2)
    assert [row["repeat"] for row in rows] == [0, 1]
    for row in rows:
        assert row["in_process_ms"] > 0 and row["own_process_ms"] > 0 and row["sandbox_ms"] > 0
        assert row["own_process_ratio"] == pytest.approx(row["own_process_ms"] / row["in_process_ms"])
        assert row["sandbox_ratio"] == pytest.approx(row["sandbox_ms"] / row["in_process_ms"])
        assert min(row[f"predict_{side}_ms"] for side in ("in_process", "own_process", "sandbox")) > 0


def test_the_command_writes_its_table(tmp_path: Path) -> None:
    assert main(["bench", "isolation", "--steps", "2", "--repeats", "1", "--out", str(tmp_path)]) == 0
    text = (tmp_path / "isolation_cost.md").read_text()
    assert text.startswith("# The cost of flying an outside agent apart from the scorer\n")
    assert "In its sandbox: median ratio of time per step to in process " in text
    assert "| predict in process (ms) | predict own process (ms) | predict sandbox (ms) |" in text
    assert (
        (tmp_path / "isolation_cost.csv")
        .read_text()
        .startswith(
            "repeat,in_process_ms,own_process_ms,sandbox_ms,own_process_ratio,sandbox_ratio,predict_in_process_ms,"
        )
    )


@pytest.mark.parametrize(("steps", "repeats"), [(0, 1), (1, 0)])
def test_bad_counts_are_refused(steps: int, repeats: int) -> None:
    with pytest.raises(ValueError, match=rf"^steps and repeats must be >= 1, got {steps} and {repeats}$"):
        measure_isolation_cost(steps=steps, repeats=repeats)
