"""Agents and everything done with them: policies, training, evaluation and sweeps, the analysis of their
episodes, speed benchmarks, the thesis experiments and the ``flownav`` command line (one subpackage each; see
the README's tour)."""

__all__ = ["__version__"]


def __getattr__(name: str) -> str:
    # The version is the estimator's (one owner), read only when asked: importing the analysis loads no OpenCV.
    if name == "__version__":
        from estimator import __version__

        return __version__
    raise AttributeError(f"module 'agents' has no attribute {name!r}")
