"""Shared test set-up: headless MuJoCo rendering, and a signing key of the tests' own (shared helpers and data
paths are in ``helpers.py``)."""

from __future__ import annotations

import os
import tempfile

# flownav_env owns the headless GL default; importing it first sets it before any test module imports mujoco.
import flownav_env  # noqa: F401

# The key verifications are signed with lives in the user's config folder: tests sign with a key of their own.
os.environ["XDG_CONFIG_HOME"] = tempfile.mkdtemp(prefix="flownav-test-config-")
