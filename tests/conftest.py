"""Shared test set-up: headless MuJoCo rendering and the location of the third-party test data."""

from __future__ import annotations

import os
from pathlib import Path

# The GL backend is read when mujoco is first imported, so it must be set before any test module imports it.
os.environ.setdefault("MUJOCO_GL", "egl")

TESTDATA = Path(__file__).resolve().parents[2] / "shared" / "testdata"
