"""A run whose flight failed gives its claim up: another run flies that episode at once, instead of waiting
for the claim to expire while the failed run's process lives on."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from agents.evaluation.claims import CLAIMED, MINE, claim_episode

IDENTITY = ("my_agent.py:make", "clean", 0.0, 2_000_000, None, "1")

CLAIM_AND_STAY = """
import sys, time
from agents.evaluation.claims import claim_episode, release_claim
identity = {identity!r}
claim_episode(sys.argv[1], identity)
if sys.argv[2] == "release":
    release_claim(sys.argv[1], identity)
print("claimed", flush=True)
time.sleep(60)
"""


@pytest.mark.parametrize(("then", "found"), [("keep", CLAIMED), ("release", MINE)])
def test_a_released_claim_of_a_live_run_no_longer_holds_the_episode(
    then: str, found: str, tmp_path: Path
) -> None:
    csv_path = tmp_path / "episodes.csv"
    other_run = subprocess.Popen(
        [sys.executable, "-c", CLAIM_AND_STAY.format(identity=IDENTITY), str(csv_path), then],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert other_run.stdout is not None and other_run.stdout.readline() == "claimed\n"
        assert claim_episode(csv_path, IDENTITY) == found
    finally:
        other_run.kill()
        other_run.wait()
