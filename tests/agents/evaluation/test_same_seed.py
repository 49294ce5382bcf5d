"""Same seeds, same episodes: records flown now equal those flown before the restructure.

``tests/data/same_seed_episodes.csv`` was first flown by commit 1f10a6b, before ``agents/`` was cut into
subpackages and the env's settings and sensor pipeline got one owner each; the restructure and the trust fixes
(episode identity, checked resumes) left every record identical. The throughput work changed episodes on
purpose (the controller on plain floats rounds differently, and the backward LK check starts from the forward
track's origin), again when capsules got a coarser mesh for faster rendering, and again when the camera's near
plane moved from 1.22 m to 5 cm (near capsules had rendered hollow), and when the bee was re-tuned after that
(2026-12-02), so the file was flown again each time, with the same tasks as below (see CHANGELOG.md);
it was flown once more when episodes gained ``mean_depth_outlier_share``, every other value unchanged, and again when
``path_length_m`` began to count the first step (from reset's position; the rules' other values unchanged).
The physics, rendering, estimator and policies are deterministic for a seed on one machine, so any difference
is a change of behaviour; across CPUs only the last bits of float sums may differ (see below). A deliberate change of behaviour regenerates the file
(``record_same_seed_episodes`` below) and says so in CHANGELOG.md.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

from agents.evaluation.episode_tasks import EpisodeTask
from agents.evaluation.runner import execute

GOLDEN = Path(__file__).resolve().parents[2] / "data" / "same_seed_episodes.csv"
TASKS = [
    *(
        EpisodeTask(agent, "clean", 0.0, seed)
        for agent in ("straight", "bee", "ppo_flow")
        for seed in (1_000_000, 1_000_001)
    ),
    EpisodeTask(
        "bee",
        "rotation_error",
        0.3,
        1_000_002,
        env_kwargs=(("rotation_error", 0.3), ("attitude_jitter_deg", 2.0)),
    ),
]


def record_same_seed_episodes(path: Path) -> None:
    """Fly :data:`TASKS` into the episodes CSV ``path``."""
    execute(TASKS, path)


# The golden file was flown on another CPU than some that run this test: BLAS and SIMD kernels differ in the
# last bits of floating-point sums between instruction sets. The reactive rules read binned counts, so their
# flights stay identical and only float diagnostics (a median depth error) move, by about 1e-16 relative; a
# learned policy acts on continuous values and a flight amplifies such bits into a different path. Hence:
# reactive episodes match the golden file (floats to 1e-9 relative, everything else exactly); the learned one
# must repeat itself exactly on this machine.
LEARNED = {"ppo_flow"}
FLOAT_REL_TOL = 1e-9


def _same(before: str, now: str) -> bool:
    if before == now:
        return True
    try:
        return math.isclose(float(before), float(now), rel_tol=FLOAT_REL_TOL, abs_tol=0.0)
    except ValueError:
        return False


def _without_provenance(row: dict[str, str]) -> dict[str, str]:
    # The commit that flew a row and the row's checksum (which covers it) change with every commit.
    return {key: value for key, value in row.items() if key not in {"code_version", "row_crc"}}


def test_same_seeds_give_identical_episode_records(tmp_path: Path) -> None:
    flown = tmp_path / "episodes.csv"
    record_same_seed_episodes(flown)
    with GOLDEN.open(newline="") as expected_file, flown.open(newline="") as flown_file:
        expected, actual = list(csv.DictReader(expected_file)), list(csv.DictReader(flown_file))
    assert len(actual) == len(expected) == len(TASKS)
    for before, now in zip(expected, actual, strict=True):
        assert now["env_id"] == "FlowNav-v0" and now["row_crc"]
        if before["agent"] in LEARNED:
            continue
        before = _without_provenance(before)
        changed = {key: (value, now[key]) for key, value in before.items() if not _same(value, now[key])}
        assert not changed, f"episode {before['agent']} seed {before['seed']} changed: {changed}"
    # The learned agent's episodes, flown again from scratch, repeat to the last digit.
    again = tmp_path / "again.csv"
    execute([task for task in TASKS if task.agent in LEARNED], again)
    with again.open(newline="") as again_file:
        repeated = list(csv.DictReader(again_file))
    first = [_without_provenance(row) for row in actual if row["agent"] in LEARNED]
    assert [_without_provenance(row) for row in repeated] == first
