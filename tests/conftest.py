"""Shared test set-up: headless MuJoCo rendering and the location of the third-party test data."""

from __future__ import annotations

from pathlib import Path

# flownav_env owns the headless GL default; importing it first sets it before any test module imports mujoco.
import flownav_env  # noqa: F401

TESTDATA = Path(__file__).resolve().parents[2] / "shared" / "testdata"
