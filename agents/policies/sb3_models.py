"""A stable-baselines3 model of any algorithm, trained anywhere, scored without running code from its file.

``--policy model.zip --algo sac`` names the agent ``sac:/abs/path/model.zip``. The model's policy network is
rebuilt from the algorithm's ``MultiInputPolicy`` (``MultiInputLstmPolicy`` for RecurrentPPO), its saved
``policy_kwargs`` (kept as plain JSON in the zip) and the spaces of a FlowNav env that gives every observation
key its parameters read; only the parameters are loaded (``torch.load(weights_only=True)``). A model whose
``policy_kwargs`` were pickled (a custom activation or extractor class) can only be read by unpickling it,
which runs code: that takes ``trust_pickle``.
"""

from __future__ import annotations

import base64
import functools
import hashlib
import io
import pickle
import re
from pathlib import Path
from typing import Any

from agents.common.saved_models import SavedModel, read_saved_model
from agents.policies.base import Agent
from agents.policies.observation_keys import OBSERVATION_KEY_SETTINGS, CheckedPolicy, ObservationKeyCheck

SB3_ALGORITHMS = ("ppo", "sac", "a2c", "td3", "recurrent_ppo")


def algorithm(name: str) -> Any:
    """The stable-baselines3 (or sb3-contrib) class of the algorithm ``name``.

    Raises:
        ValueError: not one of :data:`SB3_ALGORITHMS`.
    """
    if name not in SB3_ALGORITHMS:
        raise ValueError(f"--algo must be one of {', '.join(SB3_ALGORITHMS)}, got {name!r}")
    if name == "recurrent_ppo":
        from sb3_contrib import RecurrentPPO

        return RecurrentPPO
    import stable_baselines3

    return getattr(stable_baselines3, name.upper())


def sb3_model_name(algo: str, path: str | Path) -> str:
    """The agent name of the model ``path`` of algorithm ``algo``: ``sac:/abs/path/model.zip``."""
    algorithm(algo)
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


def sb3_model_env_settings(name: str) -> dict[str, Any]:
    """The env settings that give every observation key the model was trained on (``observe_approach`` for
    an ``approach`` input, ...), read from the text form of its observation space that SB3 saves beside the
    pickled one: what the model must fly with."""
    space = _saved(_split(name)[1]).data.get("observation_space")
    text = space.get("spaces", "") if isinstance(space, dict) else ""
    keys = set(re.findall(r"'(\w+)': (?:Box|Discrete|MultiDiscrete|MultiBinary)\(", str(text)))
    return {OBSERVATION_KEY_SETTINGS[key]: True for key in sorted(keys) if key in OBSERVATION_KEY_SETTINGS}


def sb3_model_parameters(name: str) -> dict[str, Any]:
    """What identifies the model in episode records: its algorithm and the hash of its file."""
    algo, path = _split(name)
    return {"algo": algo, "model_sha256": hashlib.sha256(path.read_bytes()).hexdigest()}


# What a saved policy_kwargs may name without unpickling arbitrary code: installed classes of torch and SB3
# (an optimiser, an activation, a features extractor), never a function to call with the file's arguments.
_SAFE_MODULES = ("torch.optim", "torch.nn.modules.activation", "stable_baselines3.common.torch_layers")


class _ClassesOnly(pickle.Unpickler):
    def find_class(self, module: str, name: str) -> Any:
        if module.split(".")[0] in ("torch", "stable_baselines3") and module.startswith(_SAFE_MODULES):
            return super().find_class(module, name)
        raise pickle.UnpicklingError(f"{module}.{name} is not a torch or SB3 class")

    def persistent_load(self, pid: Any) -> Any:
        raise pickle.UnpicklingError("persistent ids are refused")


def _classes_only(serialized: str) -> dict[str, Any] | None:
    """The pickled ``policy_kwargs`` when they name nothing but torch's optimisers and activations or SB3's
    extractors (A2C saves its RMSprop optimiser so); None when they name anything else."""
    try:
        value = _ClassesOnly(io.BytesIO(base64.b64decode(serialized))).load()
    except Exception:  # refused or malformed: only trust_pickle may read it
        return None
    return value if isinstance(value, dict) else None


def load_sb3_model(name: str, *, trust_pickle: bool = False) -> Agent:
    """The model named ``name`` (``<algo>:<path>.zip``) as an agent, its parameters loaded into a network built
    here (see the module docstring).

    Raises:
        FileNotFoundError: no such file.
        ValueError: not a stable-baselines3 model, ``policy_kwargs`` pickled with other than torch's or SB3's
            classes without ``trust_pickle``, or
            parameters that do not fit the algorithm's network on FlowNav's spaces; the message names the file.
    """
    import gymnasium as gym

    import flownav_env  # noqa: F401  (registers the env ids)

    algo, path = _split(name)
    algorithm_class = algorithm(algo)
    saved = _saved(path)
    network = saved.data.get("policy_kwargs") or {}
    if isinstance(network, dict) and ":serialized:" in network:
        network = _classes_only(network[":serialized:"])
    if not isinstance(network, dict):
        if not trust_pickle:
            raise ValueError(
                f"{path}: its policy_kwargs are pickled (a custom class), so only unpickling it, which runs code "
                "from the file, can rebuild its network: pass --trust-pickle (trust_pickle=True) if you trust it"
            )
        return CheckedPolicy(algorithm_class.load(path, device="cpu"), ObservationKeyCheck((), path, None))
    env = gym.make("FlowNav-v0", **sb3_model_env_settings(name))
    try:
        observation_space, action_space = env.observation_space, env.action_space
    finally:
        env.close()
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
