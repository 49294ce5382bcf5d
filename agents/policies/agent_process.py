"""An outside agent (a file, a module, a model zip) in a process of its own, apart from the env.

The scoring process keeps the env, its physics and its layout; the agent's process
(:mod:`agents.policies.agent_server`) is sent each observation and sends back an action as plain numbers, so
nothing the agent's code does (walking ``gc.get_objects()``, patching a module, ``sys.exit``) reaches the env.
What comes back is never unpickled: an action is a shape and float64 bytes, the agent's declarations are JSON,
an error is a line of text. The agent's process runs in a process group of its own under a memory limit
(``RLIMIT_AS``) and a CPU-time limit (``RLIMIT_CPU``); the group (the agent and any process it started) is
killed when the agent is closed, when it dies, past ``--step-timeout``, and when the process that started it
ends. However it ends, :class:`AgentProcessEnded` says so in one line naming the agent and the episode.
"""

from __future__ import annotations

import atexit
import json
import math
import os
import pickle
import signal
import socket
import struct
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from multiprocessing.connection import Connection
from pathlib import Path
from typing import NoReturn, TypedDict

import numpy as np

from agents.policies.agent_limits import (
    AGENT_CPU_OPTION,
    AGENT_MEMORY_OPTION,
    AgentLimits,
    PredictTimeout,
    timeout_message,
)
from agents.policies.sandbox import (
    agent_paths,
    check_sandbox,
    make_undumpable,
    sandbox_command,
    sandbox_environment,
)

# How long an agent's process may take to import and build the agent before it answers.
STARTUP_TIMEOUT_S = 300.0
# The most an error line from the agent's process may hold: it is printed, never parsed.
MAX_ERROR_CHARS = 2000
# What the agent's process sends: its declarations (JSON), an action (shape and float64s), an error line.
DECLARED, ACTION, ERROR = b"d", b"a", b"e"
# How long a process whose connection closed may take to exit on its own before its group is killed.
EXIT_WAIT_S = 5.0
# The dimensions an action may have ((3,) or a (1, 3) batch).
MAX_ACTION_DIMS = 4
# How a shell, and bubblewrap, report a child ended by signal N: exit status 128 + N.
SIGNAL_EXIT_BASE = 128


class AgentProcessEnded(ValueError):
    """The outside agent's process ended or answered with something that is not an action: one line naming
    the agent and the episode. A ValueError: the agent is the user's to fix (``flownav`` exits 2)."""


@dataclass(frozen=True)
class AgentDeclarations:
    """What an outside agent declares, as its process reported it in JSON: the env settings it asks for
    (plain values only), whether it is privileged, the file that defines it and where its ``predict`` is."""

    env_settings: dict[str, object]
    privileged: bool
    source: str
    predict_at: str


class DeclarationsMessage(TypedDict):
    """An outside agent's declarations as its process sends them, in JSON (read into
    :class:`AgentDeclarations`)."""

    env_settings: dict[str, object]
    privileged: bool
    source: str
    predict_at: str


def check_plain_settings(agent: str, settings: object) -> dict[str, object]:
    """``settings`` if it maps setting names to plain values: exactly ``bool``, ``int``, ``float`` or ``str`` (a
    subclass could compare equal to anything), or a list or tuple of ``int`` and ``float`` (the histogram's
    ``histogram_sectors`` and ``depth_bin_edges``), which is returned as a tuple, the type the env's settings use.

    Raises:
        ValueError: one line naming the agent and the first setting that is not such a value.
    """
    if type(settings) is not dict or not all(type(key) is str for key in settings):
        raise ValueError(
            f"agent {agent}: env_settings must map env setting names to values, got {settings!r}"
        )
    checked: dict[str, object] = {}
    for key, value in settings.items():
        if type(value) in (list, tuple) and all(type(item) in (int, float) for item in value):
            checked[key] = tuple(value)
        elif type(value) in (bool, int, float, str):
            checked[key] = value
        else:
            raise ValueError(
                f"agent {agent}: env_settings[{key!r}] is a {type(value).__name__}, not a plain bool, int, float "
                "or str, nor a list of numbers"
            )
    return checked


class IsolatedAgent:
    """The outside agent ``spec`` behind FlowNav's ``predict``, running in its own process (started on first use,
    again after :meth:`close`). Its recurrent state stays in its process: ``predict`` returns ``(action, None)``
    and the agent's process resets its state where ``episode_start`` says an episode starts.

    ``step_timeout_s`` (0: no limit) and ``episode`` (the episode in words, for messages) are set by whoever
    flies it before each episode.
    """

    def __init__(self, spec: str, *, trust_pickle: bool = False, limits: AgentLimits | None = None) -> None:
        self.spec = spec
        self.trust_pickle = trust_pickle
        self.limits = limits or AgentLimits()
        self.step_timeout_s = 0.0
        self.episode = ""
        self._process: subprocess.Popen[bytes] | None = None
        self._connection: Connection | None = None
        self._declared: AgentDeclarations | None = None
        self.log_path: Path | None = None

    def declarations(self) -> AgentDeclarations:
        """What the agent declares, as its first process in this process said (it is started if it never ran):
        what the env is built with and checked against here, whatever a later process of it says.

        Raises:
            ValueError: the agent does not load, or declares settings that are not plain values.
        """
        if self._declared is None:
            self._ensure_started()
        assert self._declared is not None  # set by _ensure_started
        return self._declared

    def predict(
        self,
        observation: dict[str, np.ndarray],
        state: object = None,
        episode_start: np.ndarray | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, object]:
        """The agent's action for ``observation``, computed in its process.

        Raises:
            PredictTimeout: no answer within ``step_timeout_s``.
            AgentProcessEnded: the agent's process ended, or sent something that is not an action.
            ValueError: the agent's ``predict`` raised, read a key the env does not give, or returned an action
                that is not finite numbers; one line naming the agent and the episode.
        """
        self._ensure_started()
        assert self._connection is not None
        starts = bool(np.asarray(episode_start).any()) if episode_start is not None else state is None
        message = pickle.dumps(({k: np.asarray(v) for k, v in observation.items()}, starts), protocol=5)
        try:
            self._connection.send_bytes(message)
        except OSError:
            self._ended("while it was sent an observation")
        timeout = self.step_timeout_s if self.step_timeout_s > 0 else None
        if not self._connection.poll(timeout):
            self.close()
            raise PredictTimeout(
                timeout_message(self.spec, self.episode or "an episode", self.step_timeout_s)
            )
        kind, body = self._receive("during predict")
        if kind == ERROR:
            raise ValueError(f"{_text(body)}{self._in_episode()}")
        if kind != ACTION:
            self._ended("during predict", f"it sent a {kind!r} message, not an action")
        action = self._action(body)
        if not np.isfinite(action).all():
            where = f" (its predict is at {self._declared.predict_at})" if self._declared else ""
            raise ValueError(
                f"agent {self.spec} returned the action {action.tolist()!r}{where}{self._in_episode()}: an action "
                "must be finite numbers"
            )
        return action, None

    def declared_predict_location(self) -> str | None:
        """Where the agent's own ``predict`` is written (``path/to/file.py:LINE``), as its process declared it."""
        return (self._declared.predict_at or None) if self._declared is not None else None

    def close(self) -> None:
        """End the agent's process and every process it started (its process group)."""
        process, connection = self._process, self._connection
        self._process = self._connection = None
        if connection is not None:
            connection.close()
        if process is not None:
            _kill_group(process)
            process.wait()
        if self.log_path is not None and self.log_path.is_file() and self.log_path.stat().st_size == 0:
            self.log_path.unlink()
        _RUNNING.pop(id(self), None)

    def _ensure_started(self) -> None:
        if self._process is not None:
            return
        # Nothing of the same user, sandboxed or not, may read or write this process's memory through /proc.
        make_undumpable()
        ours, theirs = socket.socketpair()
        command = [
            sys.executable,
            "-m",
            "agents.policies.agent_server",
            str(theirs.fileno()),
            self.spec,
            "1" if self.trust_pickle else "0",
            str(self.limits.memory_bytes),
            str(self.limits.cpu_s),
        ]
        if self.limits.sandboxed:
            check_sandbox()
            readable, import_from = agent_paths(self.spec)
            command = sandbox_command(command, readable, python_path=import_from)
            environment = sandbox_environment(import_from)
        else:
            # The agent's process imports what this one does: the same FlowNav, and the user's modules.
            path = os.pathsep.join(entry or os.getcwd() for entry in sys.path)
            environment = {**os.environ, "PYTHONPATH": path}
        # What the agent prints goes to a file of its own, never to the user's terminal.
        self.log_path = _new_log_path()
        with open(self.log_path, "wb") as log:
            self._process = subprocess.Popen(
                command,
                pass_fds=(theirs.fileno(),),
                stdin=subprocess.DEVNULL,
                stdout=log,
                stderr=log,
                start_new_session=True,  # a process group of its own: killed as one
                env=environment,
            )
        theirs.close()
        self._connection = Connection(ours.detach())
        _RUNNING[id(self)] = self
        if not self._connection.poll(STARTUP_TIMEOUT_S):
            self.close()
            raise AgentProcessEnded(
                f"agent {self.spec} did not load within {STARTUP_TIMEOUT_S:g} s in its process"
            )
        kind, body = self._receive("while it loaded")
        if kind == ERROR:
            self.close()
            raise ValueError(_text(body))
        if kind != DECLARED:
            self._ended("while it loaded", f"it sent a {kind!r} message, not its declarations")
        declared = self._declarations(body)  # checked on every start, kept from the first
        self._declared = self._declared or declared

    def _receive(self, when: str) -> tuple[bytes, bytes]:
        """The next message from the agent's process: its kind and its body."""
        assert self._connection is not None
        try:
            message = self._connection.recv_bytes()
        except (EOFError, OSError):
            self._ended(when)
        return message[:1], message[1:]

    def _declarations(self, body: bytes) -> AgentDeclarations:
        try:
            declared = json.loads(body.decode())
            settings = check_plain_settings(self.spec, declared["env_settings"])
            privileged = declared["privileged"]
            if type(privileged) is not bool:
                raise ValueError(f"agent {self.spec}: privileged must be True or False, got {privileged!r}")
            return AgentDeclarations(
                settings, privileged, str(declared["source"]), str(declared["predict_at"])
            )
        except (UnicodeDecodeError, json.JSONDecodeError, KeyError, TypeError) as error:
            self.close()
            raise AgentProcessEnded(
                f"agent {self.spec}'s process sent declarations that are not FlowNav's ({type(error).__name__})"
            ) from None
        except ValueError:
            self.close()
            raise

    def _action(self, body: bytes) -> np.ndarray:
        """The action in ``body``: a byte of dimensions, as many int32 sizes, then float64 values."""
        if len(body) >= 1 and body[0] <= MAX_ACTION_DIMS:
            dims = body[0]
            header = 1 + 4 * dims
            shape = struct.unpack(f"<{dims}i", body[1:header]) if len(body) >= header else None
            if shape is not None and all(size >= 0 for size in shape):
                values = np.frombuffer(body[header:], dtype="<f8")
                if values.size == math.prod(shape):
                    return values.reshape(shape).copy()
        self._ended("during predict", "it sent an action that is not a shape and numbers")

    def _ended(self, when: str, why: str = "") -> NoReturn:
        """Close the agent and raise :class:`AgentProcessEnded`, saying how its process ended."""
        process = self._process
        if process is not None and not why:
            try:  # its own ending first: killing its group now would hide how it ended
                process.wait(EXIT_WAIT_S)
            except subprocess.TimeoutExpired:
                pass
        self.close()
        how = why or (_exit_description(process, self.limits) if process is not None else "it was closed")
        output = (
            f"; what it printed is in {self.log_path}"
            if self.log_path is not None and self.log_path.is_file()
            else ""
        )
        raise AgentProcessEnded(
            f"agent {self.spec}'s process ended {when}{self._in_episode()} ({how}); the run stopped and that "
            f"episode is not recorded{output}"
        )

    def _in_episode(self) -> str:
        return f" in {self.episode}" if self.episode else ""


def _text(body: bytes) -> str:
    """An error line from the agent's process: one line, cut to :data:`MAX_ERROR_CHARS`."""
    return " ".join(body.decode(errors="replace").split())[:MAX_ERROR_CHARS]


def _new_log_path() -> Path:
    """A new file in this user's temporary folder for what an agent's process prints."""
    descriptor, name = tempfile.mkstemp(prefix="flownav-agent-", suffix=".log")
    os.close(descriptor)
    return Path(name)


def _exit_description(process: subprocess.Popen[bytes], limits: AgentLimits) -> str:
    """How ``process`` (already waited for) ended, with the limit that ended it where one did."""
    status = process.returncode
    if status is not None and limits.sandboxed and SIGNAL_EXIT_BASE < status < SIGNAL_EXIT_BASE + 65:
        status = SIGNAL_EXIT_BASE - status  # the sandbox exits 128 + N for an agent ended by signal N
    if status is None or status >= 0:
        return f"it exited with status {status}"
    number = -status
    name = signal.Signals(number).name if number in signal.valid_signals() else f"signal {number}"
    if number == signal.SIGXCPU:
        return f"killed by {name}: it used its {limits.cpu_s:g} s of CPU time ({AGENT_CPU_OPTION})"
    if number == signal.SIGKILL:
        return (
            f"killed by {name}: past its {limits.cpu_s:g} s of CPU time ({AGENT_CPU_OPTION}), by the system's "
            f"out-of-memory killer, or by another process; its memory limit is {limits.memory_gib:g} GiB "
            f"({AGENT_MEMORY_OPTION})"
        )
    if number == signal.SIGSEGV:
        return f"killed by {name}, as when memory runs out past its {limits.memory_gib:g} GiB ({AGENT_MEMORY_OPTION})"
    return f"killed by {name}"


def _kill_group(process: subprocess.Popen[bytes]) -> None:
    """Kill the process group ``process`` leads (it and what it started); before ``process`` is waited for, so
    the group's id still names it."""
    try:
        os.killpg(process.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass


# Every agent process this process has running, so that all end with it.
_RUNNING: dict[int, IsolatedAgent] = {}
# One agent process per (spec, trust_pickle, limits) in this process, shared by whoever flies it.
_SHARED: dict[tuple[str, bool, AgentLimits], IsolatedAgent] = {}


def isolated_agent(
    spec: str, *, trust_pickle: bool = False, limits: AgentLimits | None = None
) -> IsolatedAgent:
    """This process's :class:`IsolatedAgent` for ``spec`` with these options (not started until used)."""
    key = (spec, trust_pickle, limits or AgentLimits())
    if key not in _SHARED:
        _SHARED[key] = IsolatedAgent(spec, trust_pickle=trust_pickle, limits=key[2])
    return _SHARED[key]


def end_agent_processes() -> None:
    """Close every outside agent's process this process started (each starts again when next used)."""
    for agent in list(_RUNNING.values()):
        agent.close()


atexit.register(end_agent_processes)
