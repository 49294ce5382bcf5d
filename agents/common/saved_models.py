"""stable-baselines3 model files (``.zip``): written atomically, read without unpickling, and the newest
checkpoint that reads.

A ``kill -9`` or a full disk during ``model.save`` leaves a truncated zip; written under a temporary name and
renamed, a file is either the old one or the complete new one. Reading uses only ``zipfile``, ``json`` and
``torch.load(weights_only=True)``: the ``data`` entry's pickled objects (spaces, schedules, the policy class)
are never unpickled, since unpickling runs whatever code the file names (:func:`load_unpickled` does, for a
file the user trusts).
"""

from __future__ import annotations

import io
import json
import re
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from agents.common.folders import naming_file, replacing_atomically
from agents.common.interrupts import stop_signals_deferred

if TYPE_CHECKING:
    from stable_baselines3.common.base_class import BaseAlgorithm

CHECKPOINT_NAME = re.compile(r"_(\d+)_steps$")
REQUIRED_ENTRIES = ("data", "policy.pth")


@dataclass(frozen=True)
class SavedModel:
    """What a model zip holds that can be read safely: its ``data`` as plain JSON (pickled values stay
    base64 strings) and the policy's parameters."""

    path: Path
    data: dict[str, Any]
    policy_state: dict[str, Any]

    @property
    def num_timesteps(self) -> int:
        """Environment steps the model had learned from when saved."""
        return int(self.data.get("num_timesteps", 0))


def read_saved_model(path: Path) -> SavedModel:
    """Read a stable-baselines3 model zip without running code from it.

    Raises:
        FileNotFoundError: no such file.
        ValueError: not a zip (or cut short), no ``data``/``policy.pth`` entries (not an SB3 model), ``data``
            not JSON, or ``policy.pth`` not a weights-only state dict; the message names the file.
    """
    # torch is heavy: imported only when a model is read, not by everything that imports this bottom layer.
    import torch

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"model file not found: {path}")
    try:
        with zipfile.ZipFile(path) as archive:
            names = archive.namelist()
            # SB3 stores its entries uncompressed, and policy.pth is itself a zip: in a file cut short, zipfile
            # finds that inner zip's directory, whose entries start past byte 0, and lists torch's entries.
            start = min((entry.header_offset for entry in archive.infolist()), default=0)
            if start > 0:
                raise ValueError(
                    f"{path} is cut short: not a readable zip file (its own directory is missing; what reads is "
                    f"a zip stored inside it from byte {start})"
                )
            missing = [entry for entry in REQUIRED_ENTRIES if entry not in names]
            if missing:
                raise ValueError(
                    f"{path} is not a stable-baselines3 model: it lacks {', '.join(missing)} "
                    f"(entries: {', '.join(names[:8]) or 'none'})"
                )
            raw_data = archive.read("data")
            raw_policy = archive.read("policy.pth")
    except (zipfile.BadZipFile, EOFError, OSError) as error:
        raise ValueError(f"{path} is not a readable zip file (cut short or not a model): {error}") from error
    try:
        data = json.loads(raw_data.decode())
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise ValueError(
            f"{path}: its 'data' entry is not valid JSON (file cut or edited): {error}"
        ) from error
    if not isinstance(data, dict):
        raise ValueError(f"{path}: its 'data' entry is not a JSON object")
    try:
        state = torch.load(io.BytesIO(raw_policy), map_location="cpu", weights_only=True)
    except Exception as error:  # torch raises many types for a bad or unsafe file; all mean "not weights"
        raise ValueError(
            f"{path}: its policy.pth is not a weights-only parameter file: {type(error).__name__}: {error}"
        ) from error
    if not isinstance(state, dict):
        raise ValueError(f"{path}: its policy.pth holds a {type(state).__name__}, not a parameter dict")
    return SavedModel(path, data, state)


def describe_error(error: BaseException) -> str:
    """``error`` as one line, ``TypeError: what it said``, whatever newlines its message holds."""
    text = " ".join(str(error).split())
    return f"{type(error).__name__}: {text}" if text else type(error).__name__


def load_unpickled(algorithm_class: type[BaseAlgorithm], path: Path, label: str) -> BaseAlgorithm:
    """``algorithm_class.load(path)`` on the CPU: SB3's own load, which unpickles the zip and so runs any code
    it names; only for a file the user said they trust (``--trust-pickle``).

    Raises:
        ValueError: the load raised anything (a broken file, or a payload that fails inside SB3); one line
            naming the file and the ``label`` (``PPO``, ``sac``) it was loaded as.
    """
    try:
        return algorithm_class.load(path, device="cpu")
    except Exception as error:  # SB3 and whatever the file names raise any type; all mean "not loadable"
        raise ValueError(
            f"{path} could not be loaded as a {label} model (unpickled, as --trust-pickle asked): "
            f"{describe_error(error)}"
        ) from error


def save_atomically(model: BaseAlgorithm, path: Path) -> Path:
    """``model.save(path)`` through :func:`agents.common.folders.replacing_atomically`, so an interrupted save
    never leaves a truncated ``path``; returns ``path``.

    Raises:
        OSError: the save failed (full disk, file-size limit, read-only folder); it names ``path``, and the
            partial temporary file is removed.
    """
    path = Path(path)
    with naming_file(path):
        path.parent.mkdir(parents=True, exist_ok=True)
    # A stop that arrives mid-save takes effect once the file is whole.
    with stop_signals_deferred(), replacing_atomically(path) as temporary:
        model.save(temporary)
    return path


def checkpoint_steps(path: Path) -> int | None:
    """The step count in a checkpoint's name (``ppo_flow_4096_steps.zip`` → 4096), None for other names."""
    match = CHECKPOINT_NAME.search(Path(path).stem)
    return int(match.group(1)) if match else None


def latest_checkpoint(directory: Path) -> Path | None:
    """The newest checkpoint in ``directory`` that reads; newer ones that do not (cut short by a crash) are
    skipped with a printed warning. None when there is none."""
    candidates = [(checkpoint_steps(p), p) for p in Path(directory).glob("*_steps.zip")]
    for _, path in sorted(((s, p) for s, p in candidates if s is not None), reverse=True):
        try:
            read_saved_model(path)
        except ValueError as error:
            print(f"warning: skipping checkpoint {path}: {error}")
            continue
        return path
    return None


def load_policy_weights(model: BaseAlgorithm, path: Path) -> SavedModel:
    """Set ``model``'s policy weights to those saved in ``path`` (a curriculum's earlier stage); returns what
    was read. The optimiser and step count stay ``model``'s own.

    Raises:
        FileNotFoundError, ValueError: as :func:`read_saved_model`; ValueError also when the saved weights
            do not fit ``model``'s network (another observation, ``net_arch`` or memory); the message names
            the file and the first mismatch.
    """
    saved = read_saved_model(path)
    # Checked before loading: load_state_dict copies the tensors that fit before it raises on one that does not.
    own = model.policy.state_dict()
    mismatch = sorted(set(own) ^ set(saved.policy_state)) or [
        name for name, value in own.items() if tuple(value.shape) != tuple(saved.policy_state[name].shape)
    ]
    if mismatch:
        name = mismatch[0]
        shapes = (
            f"saved {tuple(saved.policy_state[name].shape)}, this network {tuple(own[name].shape)}"
            if name in own and name in saved.policy_state
            else ("only in the saved policy" if name in saved.policy_state else "only in this network")
        )
        raise ValueError(
            f"{path}: its policy does not fit this config's network and observation ({name}: {shapes}); "
            "init_from must name a policy trained with the same env observation, net_arch and memory"
        )
    model.policy.load_state_dict(saved.policy_state, strict=True)
    return saved
