"""Agents, training, evaluation, sweeps and the ``flownav`` command line."""

import os

# Headless rendering unless the user chose a backend: it must be set before anything imports mujoco.
os.environ.setdefault("MUJOCO_GL", "egl")
