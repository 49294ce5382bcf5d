"""The process an outside agent runs in (:mod:`agents.policies.agent_process` starts it): it limits itself,
loads the agent, reports what the agent declares, then answers each observation with an action.

Run as ``python -m agents.policies.agent_server FD SPEC TRUST_PICKLE MEMORY_BYTES CPU_S``, with FD one end of
a socket pair. It holds no env: the scoring process sends it observations only.
"""

from __future__ import annotations

import ctypes
import gc
import json
import os
import pickle
import resource
import signal
import struct
import sys
from collections.abc import Mapping
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from agents.policies.agent_limits import AGENT_MEMORY_OPTION
from agents.policies.agent_process import (
    ACTION,
    DECLARED,
    ERROR,
    MAX_ACTION_DIMS,
    DeclarationsMessage,
    check_plain_settings,
)
from agents.policies.base import Agent
from agents.policies.external import describe_error, is_external_name, load_external_agent, resolve_external
from agents.policies.sb3_models import is_sb3_model_name, load_sb3_model

# The largest file an agent's process may write (what it prints goes to a log file).
MAX_FILE_BYTES = 64 * 2**20
# prctl(PR_SET_PDEATHSIG): the signal Linux sends this process when the one that started it ends.
PR_SET_PDEATHSIG = 1


def limit_self(memory_bytes: int, cpu_s: float) -> None:
    """Cap this process's address space and CPU time (inherited by any process it starts), and end it with the
    process that started it (Linux)."""
    resource.setrlimit(resource.RLIMIT_AS, (memory_bytes, memory_bytes))
    # No file it writes, its log of what it prints included, grows past this: a write beyond fails (EFBIG).
    resource.setrlimit(resource.RLIMIT_FSIZE, (MAX_FILE_BYTES, MAX_FILE_BYTES))
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    # SIGXCPU at the limit, SIGKILL a second later if the agent ignores it; the agent cannot raise either.
    cpu = max(1, int(cpu_s))
    resource.setrlimit(resource.RLIMIT_CPU, (cpu, cpu + 1))
    # Should the scoring process die first, SIGTERM ends this process's group (the agent and what it started).
    signal.signal(signal.SIGTERM, _end_group)
    try:
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
    except (OSError, AttributeError):  # not Linux: the scoring process still kills the group when it closes
        pass


def _end_group(signum: int, frame: object) -> None:
    os.killpg(0, signal.SIGKILL)


def load(spec: str, trust_pickle: bool) -> tuple[Agent, DeclarationsMessage]:
    """The agent ``spec`` loaded here, and its declarations (JSON-ready)."""
    if is_sb3_model_name(spec):
        return load_sb3_model(spec, trust_pickle=trust_pickle), {
            "env_settings": {},
            "privileged": False,
            "source": spec.partition(":")[2],
            "predict_at": "",
        }
    if not is_external_name(spec):
        raise ValueError(f"agent {spec!r} is not an outside agent ({spec!r} names no file, module or model)")
    made, source = resolve_external(spec)
    settings = getattr(made, "env_settings", None) or {}
    settings = check_plain_settings(spec, dict(settings) if isinstance(settings, Mapping) else settings)
    privileged = getattr(made, "privileged", False)
    if type(privileged) is not bool:
        raise ValueError(f"agent {spec}: privileged must be True or False, got {privileged!r}")
    code = getattr(getattr(type(made), "predict", None), "__code__", None)
    return load_external_agent(spec), {
        "env_settings": settings,
        "privileged": privileged,
        "source": source,
        "predict_at": f"{code.co_filename}:{code.co_firstlineno}" if code else "",
    }


def action_message(spec: str, action: object) -> bytes:
    """``action`` as the scoring process reads it: a byte of dimensions, int32 sizes, float64 values."""
    try:
        values = np.asarray(action, dtype="<f8")
    except (TypeError, ValueError) as error:
        raise ValueError(f"agent {spec}: predict returned an action that is not numbers ({error})") from None
    if values.ndim > MAX_ACTION_DIMS:
        raise ValueError(f"agent {spec}: predict returned an action of shape {values.shape}, not (3,)")
    return ACTION + bytes([values.ndim]) + struct.pack(f"<{values.ndim}i", *values.shape) + values.tobytes()


def serve(connection: Connection, spec: str, agent: Agent, memory_gib: float) -> None:
    """Answer observations until the scoring process closes the connection."""
    state: Any = None
    while True:
        try:
            message = connection.recv_bytes()
        except (EOFError, OSError):
            return
        observation, starts = pickle.loads(message)  # from the scoring process, which this one trusts
        if starts:
            state = None
        try:
            action, state = agent.predict(
                observation, state=state, episode_start=np.array([starts]), deterministic=True
            )
            reply = action_message(spec, action)
        except MemoryError as error:
            reply = (
                ERROR
                + (
                    f"agent {spec}: predict ran out of memory ({describe_error(error)}) under its limit of "
                    f"{memory_gib:g} GiB ({AGENT_MEMORY_OPTION})"
                ).encode()
            )
        except Exception as error:
            line = (
                str(error)
                if isinstance(error, ValueError)
                else f"agent {spec}: predict raised {describe_error(error)}"
            )
            reply = ERROR + line.encode()
        connection.send_bytes(reply)


def main(argv: list[str]) -> int:
    descriptor, spec, trust, memory_bytes, cpu_s = argv
    limit_self(int(memory_bytes), float(cpu_s))
    connection = Connection(int(descriptor))
    try:
        agent, declared = load(spec, trust == "1")
        gc.collect()  # the env a model's spaces were read from is gone before the agent's code runs
        connection.send_bytes(DECLARED + json.dumps(declared).encode())
    except Exception as error:
        line = str(error) if isinstance(error, ValueError) else f"agent {spec}: {describe_error(error)}"
        connection.send_bytes(ERROR + line.encode())
        return 1
    serve(connection, spec, agent, int(memory_bytes) / 2**30)
    # The scoring process is done with it: whatever the agent started ends with it (its group is this one's).
    # However else it ends (sys.exit, os._exit, a signal), the scoring process kills the group.
    _end_group(signal.SIGTERM, None)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
