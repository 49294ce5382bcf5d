"""Agents written outside FlowNav: ``my_pkg.my_module:make_agent`` or ``path/to/file.py:make_agent``.

The name after the colon is a callable returning an object with stable-baselines3's ``predict``, or such an
object itself. An agent that needs env settings beyond the defaults (an optional observation key such as
``approach``, oracle depths) says so in an ``env_settings`` mapping, as shipped agents do; it is checked
against the env's settings. Its observation comes as a mapping that answers a key the env does not give with
one line naming the key and the setting that gives it, instead of a ``KeyError`` from inside ``predict``.
Episode records identify the agent by its name and the hash of the file that defines it, so a resumed run
never counts episodes of an edited agent as the new one's; tables show it by a short display name
(:func:`display_name`).

Whatever goes wrong inside the user's code (a file that does not import, a factory or ``predict`` that raises, a
``predict`` that does not return ``(action, state)``) becomes a ValueError of one line naming the agent and where
in its file it failed, so that the command line prints that line rather than a traceback from FlowNav's insides
(and, from a process pool, one per worker).
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import importlib.util
import sys
import traceback
from pathlib import Path
from types import ModuleType
from typing import NoReturn

import numpy as np

from agents.common.agent_table import published_name_like
from agents.policies.agent_process import isolated_agent
from agents.policies.base import Agent, AgentWrapper, predict_location
from agents.policies.observation_keys import OBSERVATION_KEY_SETTINGS
from agents.policies.sb3_models import is_sb3_model_name

SPEC_HELP = "module.path:callable or path/to/file.py:callable"
# What an agent's predict is called with and gives back, as SB3's; `flownav describe` prints it.
PREDICT_SIGNATURE = (
    "predict(observation, state=None, episode_start=None, deterministic=True) -> (action, state)"
)


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
def _module(target: str) -> ModuleType:
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
        try:
            spec.loader.exec_module(module)
        except Exception as error:
            del sys.modules[name]
            raise ValueError(f"agent file {target} does not import: {describe_error(error, path)}") from None
        return module
    try:
        return importlib.import_module(target)
    except Exception as error:
        raise ValueError(
            f"cannot import the agent module {target!r} ({describe_error(error)}); an external agent is {SPEC_HELP}"
        ) from None


def describe_error(error: BaseException, source: Path | str | None = None) -> str:
    """``error`` in one line: its type, its message and where it was raised, in ``source`` where the traceback
    passes through that file (the user's code, not the library it called), else at its innermost frame."""
    message = " ".join(str(error).split())
    if isinstance(error, SyntaxError):
        message = " ".join(str(error.msg).split())
        return f"SyntaxError: {message} (at {error.filename}:{error.lineno})"
    frames: list[traceback.FrameSummary] = list(traceback.extract_tb(error.__traceback__))
    if source is not None:
        wanted = str(Path(source).resolve())
        frames = [frame for frame in frames if str(Path(frame.filename).resolve()) == wanted] or frames
    where = f" (at {frames[-1].filename}:{frames[-1].lineno})" if frames else ""
    return f"{type(error).__name__}{': ' + message if message else ''}{where}"


def load_external_agent(spec: str) -> Agent:
    """In this process (the agent's own, :mod:`agents.policies.agent_server`), the agent that ``spec`` (``module.path:callable`` or ``path/to/file.py:callable``) names, with its
    observations checked (see the module docstring).

    Raises:
        ValueError: a spec without a callable name, a module or file that does not import, a missing name, or
            something without a callable ``predict``; one line naming the spec.
    """
    return ExternalAgent(spec, _resolve(spec))


def _resolve(spec: str) -> Agent:
    target, colon, attribute = str(spec).rpartition(":")
    if not colon or not target or not attribute.isidentifier():
        raise ValueError(f"agent {spec!r}: expected {SPEC_HELP}")
    module = _module(target)
    if not hasattr(module, attribute):
        raise ValueError(f"agent {spec!r}: {target} has no {attribute!r}")
    made = getattr(module, attribute)
    if isinstance(made, type) or (callable(made) and not hasattr(made, "predict")):
        try:
            made = made()  # a factory or a class; an object with predict is the agent itself
        except Exception as error:
            source = getattr(module, "__file__", None)
            raise ValueError(
                f"agent {spec!r}: calling {attribute} raised {describe_error(error, source)}"
            ) from None
    if not callable(getattr(made, "predict", None)):
        raise ValueError(
            f"agent {spec!r} gave a {type(made).__name__}, which has no predict(observation, state, "
            "episode_start, deterministic) method"
        )
    return made


def resolve_external(spec: str) -> tuple[Agent, str]:
    """The object ``spec`` names (its factory called) and the file that defines it, loaded in this process: only
    the agent's own process (:mod:`agents.policies.agent_server`) calls this.

    Raises:
        ValueError: as :func:`load_external_agent`.
    """
    made = _resolve(spec)
    return made, str(getattr(_module(str(spec).rpartition(":")[0]), "__file__", None) or "")


def external_env_settings(spec: str) -> dict[str, object]:
    """The env settings the agent ``spec`` declares it needs (its ``env_settings``; {} when it has none), as its
    own process reports them: plain ``bool``, ``int``, ``float`` or ``str`` values only.

    Raises:
        ValueError: the agent does not load, or ``env_settings`` is not a mapping of names to plain values.
    """
    return dict(isolated_agent(spec).declarations().env_settings)


def external_privileged(spec: str) -> bool:
    """Whether the agent ``spec`` declares itself privileged (``privileged = True``): it may ask for data the
    tier's sensor does not give, and is then a reference, never ranked.

    Raises:
        ValueError: ``privileged`` is set to something other than True or False.
    """
    return isolated_agent(spec).declarations().privileged


def display_name(agent: str) -> str:
    """The short name tables, CSVs and figures show for ``agent``: a file's agent by the file's stem and its
    callable (``/home/me/my_agent.py:make_agent`` -> ``my_agent:make_agent``), an SB3 model by its algorithm and
    the zip's stem (``sac:/home/me/model.zip`` -> ``sac:model``); a FlowNav agent or a module path is itself.
    Episode records keep the full spec."""
    if is_sb3_model_name(agent):
        algo, _, path = str(agent).partition(":")
        return f"{algo}:{Path(path).stem}"
    if not is_external_name(agent):
        return str(agent)
    target, _, attribute = str(agent).rpartition(":")
    return f"{Path(target).stem}:{attribute}" if _is_file_target(target) else str(agent)


def check_display_name(name: str, agent: str) -> str:
    """``name``, checked as the display name of ``agent`` in tables: one line of text that no markdown table or
    published agent would misread.

    Raises:
        ValueError: an empty name, one holding a line break, ``|`` or a backtick, or a FlowNav agent's name given
            to another agent (its included rows would replace that agent's published ones).
    """
    if not str(name).strip() or any(mark in str(name) for mark in ("\n", "\r", "|", "`")):
        raise ValueError(
            f"--name {name!r}: a display name is one line of text without '|' or backticks, e.g. my_agent"
        )
    like = published_name_like(str(name))
    if like is not None and name != agent:
        raise ValueError(
            f"--name {name!r} reads as the FlowNav agent {like!r} (names are compared after NFKC, casefolding and "
            "leaving out whitespace and invisible characters): its rows would pass for that agent's; choose another"
        )
    return str(name).strip()


def external_parameters(spec: str) -> dict[str, str]:
    """What identifies the agent ``spec`` in episode records: the hash of the file that defines it."""
    target = str(spec).rpartition(":")[0]
    # A file is hashed as it is; a module where its own process found it (this process never imports it).
    source = target if _is_file_target(target) else isolated_agent(spec).declarations().source
    digest = hashlib.sha256(Path(source).read_bytes()).hexdigest() if source else ""
    return {"source_sha256": digest}


class MissingObservationKey(ValueError):
    """The agent read an observation key the env does not give (see :class:`KeyNamingObservation`)."""


class KeyNamingObservation(dict[str, np.ndarray]):
    """An observation that answers a key the env does not give with one clear line (a ValueError) naming the
    key and the env setting that gives it."""

    def __missing__(self, key: str) -> NoReturn:
        setting = OBSERVATION_KEY_SETTINGS.get(key)
        remedy = (
            f": declare env_settings = {{{setting!r}: True}} on the agent (or make the env with {setting}=True)"
            if setting
            else f" (it gives {', '.join(sorted(self))})"
        )
        raise MissingObservationKey(
            f"the agent reads observation key {key!r}, which this env does not give{remedy}"
        )


class ExternalAgent(AgentWrapper):
    """An outside agent behind FlowNav's ``predict``: its observations as :class:`KeyNamingObservation`."""

    def __init__(self, spec: str, agent: Agent) -> None:
        super().__init__(agent)
        self.spec = spec

    def observe(self, observation: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """The observation as a :class:`KeyNamingObservation`."""
        return KeyNamingObservation(observation)

    def predict(
        self,
        observation: dict[str, np.ndarray],
        state: object = None,
        episode_start: np.ndarray | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, object]:
        """The outside agent's ``predict`` on the checked observation.

        Raises:
            ValueError: the agent read a key the env does not give, its ``predict`` raised (one line naming the
                agent and where in its code), or it returned something other than ``(action, state)``.
        """
        try:
            result = super().predict(observation, state, episode_start, deterministic)
        except (MissingObservationKey, MemoryError):  # the process around it says the memory limit
            raise
        except Exception as error:
            source = getattr(sys.modules.get(type(self.agent).__module__), "__file__", None)
            raise ValueError(f"agent {self.spec!r}: predict raised {describe_error(error, source)}") from None
        if not isinstance(result, (tuple, list)) or len(result) != 2:
            raise ValueError(
                f"agent {self.spec!r}: predict{_at(self.agent)} must return (action, state), as stable-baselines3's "
                f"does, got {_shape_of(result)}; an agent without memory returns (action, None)"
            )
        return result[0], result[1]


def _at(agent: Agent) -> str:
    """`` (at path/to/file.py:LINE)`` of ``agent``'s ``predict``, or nothing where Python cannot say."""
    where = predict_location(agent)
    return f" (at {where})" if where else ""


def _shape_of(value: object) -> str:
    """What ``value`` is, for a message: ``an ndarray of shape (3,)``, ``a tuple of 3``, ``a float``."""
    if isinstance(value, np.ndarray):
        return f"an ndarray of shape {value.shape}"
    if isinstance(value, (tuple, list)):
        return f"a {type(value).__name__} of {len(value)}"
    return f"a {type(value).__name__}"
