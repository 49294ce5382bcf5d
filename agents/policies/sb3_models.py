"""A stable-baselines3 model of any algorithm, trained anywhere, scored without running code from its file.

``--policy model.zip --algo sac`` names the agent ``sac:/abs/path/model.zip``. The model's policy network is
rebuilt from the algorithm's ``MultiInputPolicy`` (``MultiInputLstmPolicy`` for RecurrentPPO), its saved
``policy_kwargs`` (kept as plain JSON in the zip) and the spaces of a FlowNav env that gives every observation
key its parameters read; only the parameters are loaded (``torch.load(weights_only=True)``). A model whose
``policy_kwargs`` were pickled is read only when the pickle names nothing but torch's activations and
optimisers and SB3's extractors and calls nothing (:mod:`agents.policies.policy_kwargs_pickle`); any other
can only be read by unpickling it, which runs code: that takes ``trust_pickle``. ``--algo`` must be the
algorithm the zip records (:func:`recorded_algorithm`).
"""

from __future__ import annotations

import functools
import hashlib
import itertools
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from agents.common.saved_models import SavedModel, load_unpickled, read_saved_model
from agents.policies.base import Agent
from agents.policies.loading import env_spaces
from agents.policies.observation_keys import OBSERVATION_KEY_SETTINGS, CheckedPolicy, ObservationKeyCheck
from agents.policies.policy_kwargs_pickle import RefusedPickle, read_policy_kwargs_pickle

if TYPE_CHECKING:
    from stable_baselines3.common.base_class import BaseAlgorithm

SB3_ALGORITHMS = ("ppo", "sac", "a2c", "td3", "recurrent_ppo")
# The most parameters FlowNav builds a model's network with (FlowNav's own policies have about 10^5): a network
# past it is refused before it is built, rather than filling memory.
MAX_MODEL_PARAMETERS = 20_000_000


def algorithm(name: str) -> type[BaseAlgorithm]:
    """The stable-baselines3 (or sb3-contrib) class of the algorithm ``name``.

    Raises:
        ValueError: not one of :data:`SB3_ALGORITHMS`.
    """
    if name not in SB3_ALGORITHMS:
        raise ValueError(f"--algo must be one of {', '.join(SB3_ALGORITHMS)}, got {name!r}")
    # stable-baselines3 (and torch with it) is heavy, sb3-contrib optional: imported only when a model loads.
    if name == "recurrent_ppo":
        from sb3_contrib import RecurrentPPO

        return RecurrentPPO
    import stable_baselines3

    return getattr(stable_baselines3, name.upper())


def sb3_model_name(algo: str, path: str | Path) -> str:
    """The agent name of the model ``path`` of algorithm ``algo``: ``sac:/abs/path/model.zip``."""
    algorithm(algo)
    if Path(path).suffix != ".zip":
        raise ValueError(
            f"--policy {path}: a stable-baselines3 model must be a .zip file (what model.save writes), "
            f"not {Path(path).suffix or 'a name without one'}"
        )
    return f"{algo}:{Path(path).resolve()}"


def is_sb3_model_name(name: str) -> bool:
    """Whether ``name`` is an agent name made by :func:`sb3_model_name`."""
    algo, colon, path = str(name).partition(":")
    return bool(colon) and algo in SB3_ALGORITHMS and path.endswith(".zip")


def _split(name: str) -> tuple[str, Path]:
    algo, _, path = str(name).partition(":")
    return algo, Path(path)


@functools.lru_cache(maxsize=16)
def _saved(path: Path) -> SavedModel:
    return read_saved_model(path)


def sb3_model_env_settings(name: str) -> dict[str, bool]:
    """The env settings that give every observation key the model was trained on (``observe_approach`` for
    an ``approach`` input, ...), read from the text form of its observation space that SB3 saves beside the
    pickled one: what the model must fly with."""
    space = _saved(_split(name)[1]).data.get("observation_space")
    text = space.get("spaces", "") if isinstance(space, dict) else ""
    keys = set(re.findall(r"'(\w+)': (?:Box|Discrete|MultiDiscrete|MultiBinary)\(", str(text)))
    return {OBSERVATION_KEY_SETTINGS[key]: True for key in sorted(keys) if key in OBSERVATION_KEY_SETTINGS}


def sb3_model_parameters(name: str) -> dict[str, str]:
    """What identifies the model in episode records: its algorithm and the hash of its file."""
    algo, path = _split(name)
    return {"algo": algo, "model_sha256": hashlib.sha256(path.read_bytes()).hexdigest()}


@dataclass(frozen=True)
class AlgorithmRecord:
    """What an algorithm's model zip records in its ``data`` JSON, readable without unpickling: the module of
    its policy class (the ``__module__`` SB3 writes beside the pickled class), attributes only that algorithm
    saves, and attributes it never saves."""

    policy_module: str
    has: tuple[str, ...]
    lacks: tuple[str, ...] = ()

    def matches(self, data: Mapping[str, object]) -> bool:
        """Whether ``data`` (a zip's ``data`` JSON) is what this algorithm saves."""
        return (
            _policy_module(data) == self.policy_module
            and all(key in data for key in self.has)
            and not any(key in data for key in self.lacks)
        )


# PPO and A2C share a policy class; PPO alone saves its clipping and epochs, A2C no minibatch size.
ALGORITHM_RECORDS = {
    "ppo": AlgorithmRecord("stable_baselines3.common.policies", ("clip_range", "n_epochs")),
    "a2c": AlgorithmRecord(
        "stable_baselines3.common.policies", ("gae_lambda",), ("batch_size", "clip_range")
    ),
    "sac": AlgorithmRecord("stable_baselines3.sac.policies", ("target_entropy",)),
    "td3": AlgorithmRecord("stable_baselines3.td3.policies", ("policy_delay",)),
    "recurrent_ppo": AlgorithmRecord("sb3_contrib.common.recurrent.policies", ("clip_range", "n_epochs")),
}


def _policy_module(data: Mapping[str, object]) -> str | None:
    policy_class = data.get("policy_class")
    module = policy_class.get("__module__") if isinstance(policy_class, dict) else None
    return module if isinstance(module, str) else None


def recorded_algorithm(data: Mapping[str, object]) -> str | None:
    """The algorithm of :data:`SB3_ALGORITHMS` whose :data:`ALGORITHM_RECORDS` the zip's ``data`` matches; None
    when it matches none (another algorithm, or a file that records too little to tell)."""
    return next((algo for algo, record in ALGORITHM_RECORDS.items() if record.matches(data)), None)


def _check_algorithm(algo: str, saved: SavedModel) -> None:
    recorded = recorded_algorithm(saved.data)
    if recorded == algo:
        return
    if recorded is None:
        raise ValueError(
            f"{saved.path} records no algorithm FlowNav can tell (policy class module "
            f"{_policy_module(saved.data)!r}), so --algo {algo} cannot be checked: it must be a model saved by "
            f"stable-baselines3's or sb3-contrib's {', '.join(SB3_ALGORITHMS)}"
        )
    raise ValueError(
        f"{saved.path} records a {recorded} model, not the --algo {algo} asked for: pass --algo {recorded}"
    )


def network_parameters(net_arch: object, inputs: int, outputs: int) -> int:
    """About how many parameters an MLP of ``net_arch`` (SB3's: a list of layer sizes for the actor and the
    critic each, or a dict of such lists per network) has from ``inputs`` features: every weight and bias of
    each branch, to ``outputs`` values (at least one).

    Raises:
        ValueError: ``net_arch`` is not layer sizes (positive integers).
    """
    branches = list(net_arch.values()) if isinstance(net_arch, dict) else [net_arch, net_arch]
    total = 0
    for branch in branches:
        if not isinstance(branch, list) or not all(type(size) is int and size > 0 for size in branch):
            raise ValueError(f"net_arch must be lists of layer sizes (integers > 0), got {net_arch!r}")
        sizes = [inputs, *branch, max(outputs, 1)]
        total += sum(a * b + b for a, b in itertools.pairwise(sizes))
    return total


def check_network_size(path: Path, network: object, inputs: int, outputs: int) -> None:
    """Refuse a model whose network (its saved ``policy_kwargs``' ``net_arch``) would have more than
    :data:`MAX_MODEL_PARAMETERS` parameters, before it is built.

    Raises:
        ValueError: one line naming the file, its ``net_arch`` and the parameter count.
    """
    net_arch = network.get("net_arch", [64, 64]) if isinstance(network, dict) else [64, 64]
    count = network_parameters(net_arch, inputs, outputs)
    if count > MAX_MODEL_PARAMETERS:
        raise ValueError(
            f"{path}: its network (net_arch {net_arch}) would have about {count:,} parameters, more than the "
            f"{MAX_MODEL_PARAMETERS:,} FlowNav builds a model with"
        )


def load_sb3_model(name: str, *, trust_pickle: bool = False) -> Agent:
    """The model named ``name`` (``<algo>:<path>.zip``) as an agent, its parameters loaded into a network built
    here (see the module docstring).

    Raises:
        FileNotFoundError: no such file.
        ValueError: not a stable-baselines3 model, a model of another algorithm than ``<algo>`` (or one that
            records none it can tell), ``policy_kwargs`` that :func:`read_policy_kwargs_pickle` refuses without
            ``trust_pickle`` (with it: any failure of the unpickling load), or parameters that do not fit the
            algorithm's network on FlowNav's spaces; the message names the file.
    """
    algo, path = _split(name)
    algorithm_class = algorithm(algo)
    saved = _saved(path)
    _check_algorithm(algo, saved)
    network = saved.data.get("policy_kwargs") or {}
    if isinstance(network, dict) and ":serialized:" in network:
        try:
            network = read_policy_kwargs_pickle(network[":serialized:"])
        except RefusedPickle as refusal:
            if not trust_pickle:
                raise ValueError(
                    f"{path}: its policy_kwargs are pickled and the pickle {refusal}; only unpickling it, which "
                    "runs code from the file, can read it: pass --trust-pickle (trust_pickle=True) only if you "
                    "trust the file"
                ) from None
            model = load_unpickled(algorithm_class, path, algo)
            return CheckedPolicy(model, ObservationKeyCheck((), path, None))
    observation_space, action_space = env_spaces("FlowNav-v0", sb3_model_env_settings(name))
    inputs = sum(math.prod(space.shape or (1,)) for space in observation_space.spaces.values())
    check_network_size(path, network, inputs, math.prod(action_space.shape or (1,)))
    alias = "MultiInputLstmPolicy" if algo == "recurrent_ppo" else "MultiInputPolicy"
    policy = algorithm_class.policy_aliases[alias](observation_space, action_space, lambda _: 0.0, **network)
    try:
        policy.load_state_dict(saved.policy_state)
    except RuntimeError as error:
        raise ValueError(
            f"{path}: its parameters do not fit a {algo} {alias} on FlowNav's observations ({error}); is it a "
            f"{algo} model of a FlowNav env?"
        ) from None
    policy.set_training_mode(False)
    return CheckedPolicy(policy, ObservationKeyCheck(observation_space.spaces, path, None))
