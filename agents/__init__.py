"""Agents, training, evaluation, sweeps and the ``flownav`` command line."""
