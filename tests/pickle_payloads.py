"""Hand-written pickle streams that try to run code through the modules a ``policy_kwargs`` pickle may name,
and tiny real stable-baselines3 model zips to put them in. Shared by the tests of
:mod:`agents.policies.policy_kwargs_pickle`, :mod:`agents.policies.sb3_models` and
:mod:`agents.common.saved_models` (``from pickle_payloads import ...``).

Every payload is built opcode by opcode and aims at creating a marker file, so a test can check both that it
was refused and that nothing ran. Each reaches ``builtins`` through a dotted name inside an allowed module:
every module has ``__builtins__`` (a dict), so ``__builtins__.get`` called with ``"open"`` or ``"exec"``
returns that builtin.
"""

from __future__ import annotations

import base64
import json
import pickle
import struct
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

PROTOCOL_4 = pickle.PROTO + bytes([4])  # dotted names resolve from protocol 4 on


def text(value: str) -> bytes:
    """A BINUNICODE opcode pushing ``value``."""
    encoded = value.encode()
    return pickle.BINUNICODE + struct.pack("<I", len(encoded)) + encoded


def stack_global(module: str, name: str) -> bytes:
    """Push ``module`` and ``name``, then STACK_GLOBAL: the class (or whatever) they name."""
    return text(module) + text(name) + pickle.STACK_GLOBAL


def global_(module: str, name: str) -> bytes:
    """The GLOBAL opcode naming ``module`` and ``name`` in its argument."""
    return pickle.GLOBAL + f"{module}\n{name}\n".encode()


def call(callable_: bytes, *arguments: bytes) -> bytes:
    """REDUCE: call what ``callable_`` pushes with ``arguments``."""
    return callable_ + pickle.MARK + b"".join(arguments) + pickle.TUPLE + pickle.REDUCE


def builtin(module: str, name: str, lookup: Callable[[str, str], bytes] = stack_global) -> bytes:
    """Push the builtin ``name`` through ``module.__builtins__.get`` (a dotted name inside ``module``)."""
    return call(lookup(module, "__builtins__.get"), text(name))


def stream(*parts: bytes) -> bytes:
    """A protocol-4 pickle of ``parts``, ended with STOP."""
    return PROTOCOL_4 + b"".join(parts) + pickle.STOP


def encoded(payload: bytes) -> str:
    """``payload`` as SB3 stores a pickled value in a zip's ``data`` JSON: base64 text."""
    return base64.b64encode(payload).decode()


def opening(marker: Path) -> bytes:
    """The arguments ``(marker, "w")``: opening them creates ``marker``."""
    return text(str(marker)) + text("w")


def reduce_payload(module: str, marker: Path) -> bytes:
    """STACK_GLOBAL then REDUCE: ``open(marker, "w")``."""
    return stream(call(builtin(module, "open"), opening(marker)))


def global_payload(module: str, marker: Path) -> bytes:
    """GLOBAL then REDUCE: ``open(marker, "w")``."""
    return stream(call(builtin(module, "open", global_), opening(marker)))


def inst_payload(module: str, marker: Path) -> bytes:
    """INST names ``__builtins__.get`` and calls it with ``"open"``; REDUCE then opens ``marker``."""
    get_open = pickle.MARK + text("open") + pickle.INST + f"{module}\n__builtins__.get\n".encode()
    return stream(call(get_open, opening(marker)))


def obj_payload(module: str, marker: Path) -> bytes:
    """OBJ calls ``open`` (the first item after its mark) with ``(marker, "w")``."""
    return stream(pickle.MARK + builtin(module, "open") + opening(marker) + pickle.OBJ)


def build_payload(module: str, marker: Path) -> bytes:
    """BUILD sets ``__setstate__ = exec`` on the module's ``__spec__``; a second BUILD hands that ``exec`` the
    code that opens ``marker``. (``exec`` is fetched first and kept in the memo, so the first name the stream
    gives is the dotted one, as in every payload here.)"""
    keep_exec = builtin(module, "exec") + pickle.MEMOIZE + pickle.POP
    hijack = (
        pickle.EMPTY_DICT + text("__setstate__") + pickle.BINGET + bytes([0]) + pickle.SETITEM + pickle.BUILD
    )
    code = text(f"open({str(marker)!r}, 'w').close()")
    return stream(keep_exec + stack_global(module, "__spec__") + hijack + code + pickle.BUILD)


PAYLOADS: dict[str, Callable[[str, Path], bytes]] = {
    "STACK_GLOBAL+REDUCE": reduce_payload,
    "GLOBAL+REDUCE": global_payload,
    "INST": inst_payload,
    "OBJ": obj_payload,
    "BUILD": build_payload,
}
"""Each way of calling code a pickle has, as a payload that opens a marker file."""


def tiny_model(algo: str, directory: Path, **policy_kwargs: Any) -> Path:
    """A real, untrained stable-baselines3 model of ``algo`` on Pendulum (no FlowNav env: fast), saved in
    ``directory``; its ``data`` records what that algorithm records."""
    import gymnasium as gym
    from sb3_contrib import RecurrentPPO
    from stable_baselines3 import A2C, PPO, SAC, TD3

    classes = {"ppo": PPO, "a2c": A2C, "sac": SAC, "td3": TD3, "recurrent_ppo": RecurrentPPO}
    policy = "MlpLstmPolicy" if algo == "recurrent_ppo" else "MlpPolicy"
    extra = {"buffer_size": 16} if algo in ("sac", "td3") else {}
    env = gym.make("Pendulum-v1")
    model = classes[algo](
        policy, env, policy_kwargs={"net_arch": [8], **policy_kwargs}, device="cpu", **extra
    )
    path = directory / f"{algo}_model.zip"
    model.save(path)
    env.close()
    return path


def rewritten(source: Path, target: Path, change: Callable[[dict[str, Any]], None]) -> Path:
    """A copy of the model zip ``source`` at ``target`` whose ``data`` JSON ``change`` edited in place."""
    with zipfile.ZipFile(source) as original, zipfile.ZipFile(target, "w") as copy:
        for entry in original.infolist():
            content = original.read(entry)
            if entry.filename == "data":
                data = json.loads(content)
                change(data)
                content = json.dumps(data).encode()
            copy.writestr(entry, content)
    return target


def with_policy_kwargs(source: Path, target: Path, payload: bytes) -> Path:
    """A copy of ``source`` at ``target`` whose ``policy_kwargs`` are the pickle ``payload``."""

    def replace(data: dict[str, Any]) -> None:
        data["policy_kwargs"] = {":type:": "<class 'dict'>", ":serialized:": encoded(payload)}

    return rewritten(source, target, replace)
