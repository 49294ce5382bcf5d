"""Shared test set-up: headless MuJoCo rendering (shared helpers and data paths are in ``helpers.py``)."""

from __future__ import annotations

# flownav_env owns the headless GL default; importing it first sets it before any test module imports mujoco.
import flownav_env  # noqa: F401

