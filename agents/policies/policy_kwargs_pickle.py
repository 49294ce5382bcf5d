"""Reading a stable-baselines3 model's pickled ``policy_kwargs`` without letting the file call anything.

SB3 pickles ``policy_kwargs`` when they hold a class: an activation (``activation_fn=nn.Tanh``), an optimiser
(A2C saves its ``RMSprop``) or a features extractor. Such a pickle is a dict of plain values and classes, so it
needs no pickle opcode that calls something (``REDUCE``, ``BUILD``, ``INST``, ``OBJ``, ``NEWOBJ``...) and may
name only the classes of :data:`ALLOWED_CLASSES`, each by its exact module and plain name. Both are checked
before anything is built, by parsing the bytes (``pickletools.genops`` runs nothing) and following the strings
a ``STACK_GLOBAL`` takes its module and name from; the unpickler that then builds the dict checks every name
again when it looks one up. A dotted name (``stable_baselines3.common.torch_layers`` / ``th.os.system``: an
attribute path that reaches ``os`` through a module's imports) is never resolved.
"""

from __future__ import annotations

import base64
import binascii
import importlib
import io
import pickle
import pickletools
from typing import Any, NoReturn

from agents.common.saved_models import describe_error

ACTIVATION = "torch activation"
OPTIMISER = "torch optimiser"
FEATURES_EXTRACTOR = "SB3 features extractor"

_ACTIVATION_NAMES = (
    "CELU", "ELU", "GELU", "Hardsigmoid", "Hardswish", "Hardtanh", "LeakyReLU", "LogSigmoid", "Mish", "PReLU",
    "ReLU", "ReLU6", "RReLU", "SELU", "SiLU", "Sigmoid", "Softplus", "Softsign", "Tanh", "Tanhshrink",
)  # fmt: skip
_OPTIMISERS = (
    ("torch.optim.adadelta", "Adadelta"),
    ("torch.optim.adagrad", "Adagrad"),
    ("torch.optim.adam", "Adam"),
    ("torch.optim.adamax", "Adamax"),
    ("torch.optim.adamw", "AdamW"),
    ("torch.optim.nadam", "NAdam"),
    ("torch.optim.radam", "RAdam"),
    ("torch.optim.rmsprop", "RMSprop"),
    ("torch.optim.sgd", "SGD"),
)

ALLOWED_CLASSES: dict[tuple[str, str], str] = {
    **{("torch.nn.modules.activation", name): ACTIVATION for name in _ACTIVATION_NAMES},
    ("torch.nn.modules.linear", "Identity"): ACTIVATION,  # activation_fn=nn.Identity: a linear network
    **{pair: OPTIMISER for pair in _OPTIMISERS},
    **{
        ("stable_baselines3.common.torch_layers", name): FEATURES_EXTRACTOR
        for name in ("CombinedExtractor", "FlattenExtractor", "NatureCNN")
    },
}
"""Every (module, name) a ``policy_kwargs`` pickle may name, with the kind of class it must turn out to be."""

# The opcodes that build plain values (numbers, strings, containers, the memo) or look a class up; every other
# opcode calls something (REDUCE, BUILD, INST, OBJ, NEWOBJ, NEWOBJ_EX), hands a value to code outside the
# stream (PERSID, BINPERSID, the EXT registry) or reads out-of-band buffers.
_DATA_OPCODES = frozenset(
    """PROTO FRAME STOP MARK POP POP_MARK DUP NONE NEWTRUE NEWFALSE INT BININT BININT1 BININT2 LONG LONG1 LONG4
    FLOAT BINFLOAT STRING BINSTRING SHORT_BINSTRING BINBYTES SHORT_BINBYTES BINBYTES8 UNICODE BINUNICODE
    SHORT_BINUNICODE BINUNICODE8 EMPTY_LIST APPEND APPENDS LIST EMPTY_TUPLE TUPLE TUPLE1 TUPLE2 TUPLE3 EMPTY_DICT
    DICT SETITEM SETITEMS EMPTY_SET ADDITEMS FROZENSET GET BINGET LONG_BINGET PUT BINPUT LONG_BINPUT MEMOIZE
    GLOBAL STACK_GLOBAL""".split()
)


class RefusedPickle(ValueError):
    """A ``policy_kwargs`` pickle that would call code or name a class outside :data:`ALLOWED_CLASSES`; the
    message says what it holds, as a clause to follow "the pickle": "names 'system' of module 'os'..."."""


def _kind_class(kind: str) -> type:
    # torch and stable-baselines3 are heavy: imported only when a pickle names a class to check.
    import torch
    from stable_baselines3.common.torch_layers import BaseFeaturesExtractor

    return {
        ACTIVATION: torch.nn.Module,
        OPTIMISER: torch.optim.Optimizer,
        FEATURES_EXTRACTOR: BaseFeaturesExtractor,
    }[kind]


def allowed_class(module: str, name: str) -> type:
    """The class ``module``/``name`` names when it is on :data:`ALLOWED_CLASSES` and is a class of its kind.

    Raises:
        RefusedPickle: a dotted name, a pair not on the list, or something other than a class of its kind.
    """
    kind = ALLOWED_CLASSES.get((module, name))
    if kind is None:
        dotted = " (a dotted name, an attribute path inside the module)" if "." in name else ""
        raise RefusedPickle(
            f"names {name!r} of module {module!r}{dotted}, which is not one of the torch activations, torch "
            "optimisers and SB3 features extractors it may name"
        )
    # Imported by its exact name and read as one attribute: nothing the file says is called.
    value = getattr(importlib.import_module(module), name, None)
    if not (isinstance(value, type) and issubclass(value, _kind_class(kind))):
        raise RefusedPickle(
            f"names {name!r} of module {module!r}, which is not a {kind} class in this install ({value!r})"
        )
    return value


class _AllowedClassesOnly(pickle.Unpickler):
    def find_class(self, module: str, name: str) -> type:
        return allowed_class(module, name)

    def persistent_load(self, pid: object) -> NoReturn:
        raise RefusedPickle(f"holds a persistent id ({pid!r}), which is never resolved")


_MARK = object()
_MEMO_GETS = ("GET", "BINGET", "LONG_BINGET")
_MEMO_PUTS = ("PUT", "BINPUT", "LONG_BINPUT")


def _pop(stack: list[object], count: int) -> list[object]:
    if count > len(stack):
        raise ValueError("the stream pops more than it pushed")
    popped = stack[len(stack) - count :]
    del stack[len(stack) - count :]
    return popped


def _follow(
    opcode: pickletools.OpcodeInfo, arg: object, stack: list[object], memo: dict[object, object]
) -> None:
    """Apply ``opcode``'s effect on the stack and memo, keeping the values of what it pushes as literals and
    None for what it builds: enough to know the strings a STACK_GLOBAL takes its module and name from."""
    name, before, after = opcode.name, opcode.stack_before, opcode.stack_after
    if name in _MEMO_GETS:
        stack.append(memo.get(arg))
    elif name in _MEMO_PUTS:
        memo[arg] = stack[-1]
    elif name == "MEMOIZE":
        memo[len(memo)] = stack[-1]
    elif name == "DUP":
        stack.append(stack[-1])
    elif name == "MARK":
        stack.append(_MARK)
    elif not before and len(after) == 1 and arg is not None and name != "GLOBAL":
        stack.append(arg)  # a literal: a number or a string
    else:
        if pickletools.markobject in before:
            while _pop(stack, 1)[0] is not _MARK:
                pass
            _pop(stack, before.index(pickletools.markobject))
        else:
            _pop(stack, len(before))
        stack.extend(None for _ in after)


def _check_stream(stream: bytes) -> None:
    """Refuse, by parsing ``stream`` without running it, any class it names outside :data:`ALLOWED_CLASSES`
    and any opcode that calls code, in the order the stream holds them (what a call would call comes first)."""
    stack: list[object] = []
    memo: dict[object, object] = {}
    try:
        for opcode, arg, position in pickletools.genops(stream):
            if opcode.name in ("GLOBAL", "INST"):
                allowed_class(*str(arg).split(" ", 1))
            elif opcode.name == "STACK_GLOBAL":
                module, name = stack[-2:] if len(stack) >= 2 else (None, None)
                if not (isinstance(module, str) and isinstance(name, str)):
                    raise RefusedPickle(
                        f"names a class (byte {position}) whose module or name is not a string written in it"
                    )
                allowed_class(module, name)
            if opcode.name not in _DATA_OPCODES:
                raise RefusedPickle(
                    f"uses the opcode {opcode.name} (byte {position}), which calls code or hands data to code; "
                    "it may hold only plain values and classes"
                )
            _follow(opcode, arg, stack, memo)
    except RefusedPickle:
        raise
    except Exception as error:  # pickletools raises ValueError and others on a malformed stream
        raise RefusedPickle(f"is not readable ({describe_error(error)})") from None


def read_policy_kwargs_pickle(serialized: str) -> dict[str, Any]:
    """The ``policy_kwargs`` dict that the base64 pickle ``serialized`` holds, read without running anything it
    names.

    Raises:
        RefusedPickle (a ValueError): not base64, not a pickle, an opcode that calls code, a class outside
            :data:`ALLOWED_CLASSES`, or a value other than a dict.
    """
    try:
        stream = base64.b64decode(serialized, validate=True)
    except (binascii.Error, ValueError, TypeError) as error:
        raise RefusedPickle(f"is not base64 text ({describe_error(error)})") from None
    _check_stream(stream)
    try:
        value = _AllowedClassesOnly(io.BytesIO(stream)).load()
    except RefusedPickle:
        raise
    except Exception as error:  # a stream genops parsed but the unpickler cannot finish (a bad memo index)
        raise RefusedPickle(f"is not readable ({describe_error(error)})") from None
    if not isinstance(value, dict):
        raise RefusedPickle(f"holds a {type(value).__name__}, not a dict of keyword arguments")
    return value
