"""Agents written outside FlowNav: ``my_pkg.my_module:make_agent`` or ``path/to/file.py:make_agent``.

The name after the colon is a callable returning an object with stable-baselines3's ``predict``, or such an
object itself. An agent that needs env settings beyond the defaults (an optional observation key such as
``approach``, oracle depths) says so in an ``env_settings`` mapping, as shipped agents do; it is checked
against the env's settings. Its observation comes as a mapping that answers a key the env does not give with
one line naming the key and the setting that gives it, instead of a ``KeyError`` from inside ``predict``.
Episode records identify the agent by its name and the hash of the file that defines it, so a resumed run
never counts episodes of an edited agent as the new one's.
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import importlib.util
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from agents.policies.base import Agent
from agents.policies.observation_keys import OBSERVATION_KEY_SETTINGS

SPEC_HELP = "module.path:callable or path/to/file.py:callable"


def is_external_name(name: str) -> bool:
    """Whether ``name`` names an agent written outside FlowNav (it holds a colon; no shipped name does)."""
    return ":" in str(name)


def canonical_spec(spec: str) -> str:
    """``spec`` with a file path made absolute, so worker processes started elsewhere find the same file."""
    target, _, attribute = str(spec).rpartition(":")
    if _is_file_target(target):
        return f"{Path(target).resolve()}:{attribute}"
    return str(spec)


def _is_file_target(target: str) -> bool:
    return target.endswith(".py") or "/" in target


@functools.lru_cache(maxsize=32)
def _module(target: str) -> Any:
    if _is_file_target(target):
        path = Path(target)
        if not path.is_file():
            raise ValueError(f"agent file {target} not found (an external agent is {SPEC_HELP})")
        name = f"flownav_external_{hashlib.sha256(str(path.resolve()).encode()).hexdigest()[:12]}"
        spec = importlib.util.spec_from_file_location(name, path)
        if spec is None or spec.loader is None:
            raise ValueError(f"agent file {target} is not a Python module (an external agent is {SPEC_HELP})")
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module  # so pickling its classes (process pools) finds them
        spec.loader.exec_module(module)
        return module
    try:
        return importlib.import_module(target)
    except ImportError as error:
        raise ValueError(
            f"cannot import the agent module {target!r} ({error}); an external agent is {SPEC_HELP}"
        ) from None


def load_external_agent(spec: str) -> Agent:
    """The agent that ``spec`` (``module.path:callable`` or ``path/to/file.py:callable``) names, with its
    observations checked (see the module docstring).

    Raises:
        ValueError: a spec without a callable name, a module or file that does not import, a missing name, or
            something without a callable ``predict``; one line naming the spec.
    """
    return ExternalAgent(spec, _resolve(spec))


def _resolve(spec: str) -> Any:
    target, colon, attribute = str(spec).rpartition(":")
    if not colon or not target or not attribute.isidentifier():
        raise ValueError(f"agent {spec!r}: expected {SPEC_HELP}")
    module = _module(target)
    if not hasattr(module, attribute):
        raise ValueError(f"agent {spec!r}: {target} has no {attribute!r}")
    made = getattr(module, attribute)
    if isinstance(made, type) or (callable(made) and not hasattr(made, "predict")):
        made = made()  # a factory or a class; an object with predict is the agent itself
    if not callable(getattr(made, "predict", None)):
        raise ValueError(
            f"agent {spec!r} gave a {type(made).__name__}, which has no predict(observation, state, "
            "episode_start, deterministic) method"
        )
    return made


@functools.lru_cache(maxsize=32)
def external_env_settings(spec: str) -> dict[str, Any]:
    """The env settings the agent ``spec`` declares it needs (its ``env_settings``; {} when it has none).

    Raises:
        ValueError: ``env_settings`` is not a mapping of setting names to values.
    """
    declared = getattr(_resolve(spec), "env_settings", None) or {}
    if not isinstance(declared, Mapping) or not all(isinstance(key, str) for key in declared):
        raise ValueError(
            f"agent {spec!r}: env_settings must map env setting names to values, got {declared!r}"
        )
    return dict(declared)  # a copy per call would not help: lru_cache hands out this one; callers copy


def external_parameters(spec: str) -> dict[str, Any]:
    """What identifies the agent ``spec`` in episode records: the hash of the file that defines it."""
    target = str(spec).rpartition(":")[0]
    source = getattr(_module(target), "__file__", None)
    digest = hashlib.sha256(Path(source).read_bytes()).hexdigest() if source else ""
    return {"source_sha256": digest}


class KeyNamingObservation(dict):
    """An observation that answers a key the env does not give with one clear line (a ValueError) naming the
    key and the env setting that gives it."""

    def __missing__(self, key: Any) -> Any:
        setting = OBSERVATION_KEY_SETTINGS.get(key)
        remedy = (
            f": declare env_settings = {{{setting!r}: True}} on the agent (or make the env with {setting}=True)"
            if setting
            else f" (it gives {', '.join(sorted(self))})"
        )
        raise ValueError(f"the agent reads observation key {key!r}, which this env does not give{remedy}")


class ExternalAgent:
    """An outside agent behind FlowNav's ``predict``: its observations as :class:`KeyNamingObservation`."""

    def __init__(self, spec: str, agent: Any) -> None:
        self.spec = spec
        self.agent = agent

    def predict(
        self,
        observation: dict[str, np.ndarray],
        state: Any = None,
        episode_start: np.ndarray | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]:
        """The outside agent's ``predict`` on the checked observation.

        Raises:
            ValueError: the agent read a key the env does not give.
        """
        return self.agent.predict(
            KeyNamingObservation(observation),
            state=state,
            episode_start=episode_start,
            deterministic=deterministic,
        )
