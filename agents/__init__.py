"""Agents and everything done with them: policies, training, evaluation and sweeps, speed benchmarks, the
thesis experiments and the ``flownav`` command line (one subpackage each; see the README's tour)."""

from estimator import __version__

__all__ = ["__version__"]
