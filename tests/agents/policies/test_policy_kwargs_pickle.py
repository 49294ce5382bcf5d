"""A pickled ``policy_kwargs`` is read only when it names allowed classes by their exact names and calls
nothing: hand-written payloads aimed at a marker file are refused before any of them runs."""

from __future__ import annotations

import json
import pickle
import re
import subprocess
import sys
import zipfile
from pathlib import Path

import cloudpickle
import pytest
import torch
from pickle_payloads import PAYLOADS, call, encoded, global_, stack_global, stream, text, tiny_model
from stable_baselines3.common.torch_layers import CombinedExtractor, NatureCNN

from agents.policies.policy_kwargs_pickle import (
    ACTIVATION,
    ALLOWED_CLASSES,
    RefusedPickle,
    allowed_class,
    read_policy_kwargs_pickle,
)

ALLOWED_MODULES = sorted({module for module, _ in ALLOWED_CLASSES})
ACTIVATIONS = "torch.nn.modules.activation"
TORCH_LAYERS = "stable_baselines3.common.torch_layers"


def command_payload(marker: Path) -> bytes:
    """What the fault run found: ``th.os.system`` inside SB3's torch_layers, called with a shell command."""
    return stream(call(stack_global(TORCH_LAYERS, "th.os.system"), text(f"touch {marker}")))


def test_what_sb3_pickles_reads_back(tmp_path: Path) -> None:
    with zipfile.ZipFile(tiny_model("a2c", tmp_path)) as archive:  # A2C pickles its RMSprop optimiser
        serialized = json.loads(archive.read("data"))["policy_kwargs"][":serialized:"]
    kwargs = read_policy_kwargs_pickle(serialized)
    assert kwargs["optimizer_class"] is torch.optim.RMSprop and kwargs["net_arch"] == [8]
    several = {
        "activation_fn": torch.nn.Tanh,
        "optimizer_class": torch.optim.Adam,
        "features_extractor_class": CombinedExtractor,
        "features_extractor_kwargs": {"cnn_output_dim": 64, "normalized_image": False},
        "net_arch": {"pi": [64, 64], "vf": [64]},
        "optimizer_kwargs": {"eps": 1e-5, "betas": (0.9, 0.99)},
        "ortho_init": False,
        "log_std_init": -0.5,
        "second": NatureCNN,  # a second class of a module: its name comes back from the memo
    }
    assert read_policy_kwargs_pickle(encoded(cloudpickle.dumps(several))) == several
    assert read_policy_kwargs_pickle(encoded(pickle.dumps(several, protocol=2))) == several


@pytest.mark.parametrize(("module", "name"), sorted(ALLOWED_CLASSES))
def test_every_allowed_name_is_a_class_of_its_kind_in_this_install(module: str, name: str) -> None:
    found = allowed_class(module, name)
    assert isinstance(found, type) and (found.__module__, found.__name__) == (module, name)


def test_the_payloads_run_code_when_unpickled_plainly(tmp_path: Path) -> None:
    # A control: each refused payload below is a working attack, not one that would fail anyway.
    payloads = {tmp_path / "command": command_payload(tmp_path / "command")}
    for module in ALLOWED_MODULES:
        for form, payload in PAYLOADS.items():
            marker = tmp_path / f"{module}-{form}"
            payloads[marker] = payload(module, marker)
    files = []
    for marker, payload in payloads.items():
        files.append(marker.parent / f"{marker.name}.pickle")
        files[-1].write_bytes(payload)
    loads = "import pickle, sys\nfor name in sys.argv[1:]:\n    pickle.loads(open(name, 'rb').read())"
    subprocess.run([sys.executable, "-c", loads, *map(str, files)], check=True, timeout=120)
    assert [marker.name for marker in payloads if not marker.exists()] == []


@pytest.mark.parametrize("form", sorted(PAYLOADS))
@pytest.mark.parametrize("module", ALLOWED_MODULES)
def test_a_dotted_name_through_an_allowed_module_is_refused_before_it_runs(
    module: str, form: str, tmp_path: Path
) -> None:
    marker = tmp_path / "pwned"
    message = rf"^names '__builtins__\.get' of module '{re.escape(module)}' \(a dotted name"
    with pytest.raises(RefusedPickle, match=message):
        read_policy_kwargs_pickle(encoded(PAYLOADS[form](module, marker)))
    assert not marker.exists()


def test_the_command_the_fault_run_ran_is_refused_naming_its_module_and_name(tmp_path: Path) -> None:
    marker = tmp_path / "pwned"
    with pytest.raises(
        RefusedPickle, match=rf"^names 'th\.os\.system' of module '{re.escape(TORCH_LAYERS)}'"
    ):
        read_policy_kwargs_pickle(encoded(command_payload(marker)))
    assert not marker.exists()


RELU = stack_global(ACTIVATIONS, "ReLU")


@pytest.mark.parametrize(
    ("opcode", "payload"),
    [
        ("REDUCE", stream(call(RELU))),
        ("NEWOBJ", stream(RELU + pickle.EMPTY_TUPLE + pickle.NEWOBJ)),
        ("NEWOBJ_EX", stream(RELU + pickle.EMPTY_TUPLE + pickle.EMPTY_DICT + pickle.NEWOBJ_EX)),
        ("OBJ", stream(pickle.MARK + RELU + pickle.OBJ)),
        ("INST", stream(pickle.MARK + pickle.INST + f"{ACTIVATIONS}\nReLU\n".encode())),
        ("BUILD", stream(RELU + pickle.EMPTY_DICT + pickle.BUILD)),
        ("BINPERSID", stream(text("storage") + pickle.BINPERSID)),
        ("PERSID", stream(pickle.PERSID + b"storage\n")),
        ("EXT1", stream(pickle.EXT1 + bytes([1]))),
    ],
)
def test_an_opcode_that_calls_code_is_refused_even_on_an_allowed_class(opcode: str, payload: bytes) -> None:
    with pytest.raises(RefusedPickle, match=rf"^uses the opcode {opcode} \(byte \d+\), which calls code"):
        read_policy_kwargs_pickle(encoded(payload))


def test_a_name_read_back_from_the_memo_is_checked_as_one_written_out() -> None:
    # The module's string is memoised with the allowed ReLU, then reused for a dotted name.
    payload = stream(
        text(TORCH_LAYERS) + pickle.MEMOIZE + text("FlattenExtractor") + pickle.STACK_GLOBAL + pickle.POP
        + pickle.BINGET + bytes([0]) + text("th.os.system") + pickle.STACK_GLOBAL
    )  # fmt: skip
    with pytest.raises(
        RefusedPickle, match=rf"^names 'th\.os\.system' of module '{re.escape(TORCH_LAYERS)}'"
    ):
        read_policy_kwargs_pickle(encoded(payload))


@pytest.mark.parametrize(
    ("serialized", "message"),
    [
        ("%% not base64 %%", r"^is not base64 text \("),
        (encoded(pickle.PROTO + bytes([4]) + pickle.MARK), r"^is not readable \("),
        (encoded(stream(pickle.EMPTY_LIST)), r"^holds a list, not a dict of keyword arguments$"),
        (
            encoded(stream(global_("builtins", "open"))),
            r"^names 'open' of module 'builtins', which is not one",
        ),
        (
            encoded(stream(pickle.EMPTY_DICT + pickle.EMPTY_DICT + pickle.STACK_GLOBAL)),
            r"^names a class \(byte \d+\) whose module or name is not a string written in it$",
        ),
    ],
)
def test_what_is_not_a_readable_dict_of_allowed_classes_is_refused(serialized: str, message: str) -> None:
    with pytest.raises(RefusedPickle, match=message):
        read_policy_kwargs_pickle(serialized)


def test_an_allowed_name_that_is_not_a_class_of_its_kind_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    # torch.nn.modules.activation.F is torch.nn.functional, a module: listed by mistake, it is still refused.
    monkeypatch.setitem(ALLOWED_CLASSES, (ACTIVATIONS, "F"), ACTIVATION)
    with pytest.raises(
        RefusedPickle, match=r"^names 'F' of module '.*', which is not a torch activation class"
    ):
        read_policy_kwargs_pickle(encoded(stream(stack_global(ACTIVATIONS, "F"))))
