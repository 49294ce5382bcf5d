"""Same seeds, same episodes: records flown now equal those flown before the restructure (issue 11).

``tests/data/same_seed_episodes.csv`` was first flown by commit 1f10a6b, before ``agents/`` was cut into
subpackages and the env's settings and sensor pipeline got one owner each; the restructure (issue 11) and the
trust fixes (issue 12) left every record identical. The throughput work (issue 13) changed episodes on
purpose (the controller on plain floats rounds differently, and the backward LK check starts from the forward
track's origin), again when capsules got a coarser mesh for faster rendering, and again when the camera's near
plane moved from 1.22 m to 5 cm (near capsules had rendered hollow), so the file was flown again each time, with the same tasks as below (see CHANGELOG.md).
Every field must match to the last digit: the physics, rendering, estimator and policies are deterministic
for a seed, so any difference is a change of behaviour. A deliberate change of behaviour regenerates the file
(``record_same_seed_episodes`` below) and says so in CHANGELOG.md.
"""

from __future__ import annotations

import csv
from pathlib import Path

from agents.evaluation.runner import EpisodeTask, execute

GOLDEN = Path(__file__).resolve().parents[1] / "data" / "same_seed_episodes.csv"
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


def test_same_seeds_give_identical_episode_records(tmp_path: Path) -> None:
    flown = tmp_path / "episodes.csv"
    record_same_seed_episodes(flown)
    with GOLDEN.open(newline="") as expected_file, flown.open(newline="") as flown_file:
        expected, actual = list(csv.DictReader(expected_file)), list(csv.DictReader(flown_file))
    assert len(actual) == len(expected) == len(TASKS)
    # The commit that flew a row and the row's checksum (which covers it) change with every commit.
    provenance = {"code_version", "row_crc"}
    for before, now in zip(expected, actual, strict=True):
        before = {key: value for key, value in before.items() if key not in provenance}
        assert {key: now[key] for key in before} == before, (
            f"episode {before['agent']} seed {before['seed']} changed"
        )
        assert now["env_id"] == "FlowNav-v0" and now["row_crc"]
