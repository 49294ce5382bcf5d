"""Learned agents: where a trained policy is stored, the env settings it was trained with, and loading any
agent by name (a reactive one is built, a learned one is loaded from its ``.zip``, see
:mod:`agents.policies.loading`; a learned one named without a training seed flies its shipped seeds in turn,
see :mod:`agents.policies.training_seeds`)."""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym

import flownav_env  # noqa: F401  (registers the env ids that LoadedPolicy.make_env makes)
from agents.common.agent_table import AGENTS
from agents.common.locations import POLICIES_DIR
from agents.common.yaml_config import load_config
from agents.policies.agent_limits import AgentLimits
from agents.policies.agent_process import isolated_agent
from agents.policies.base import (
    Agent,
    is_learned,
    is_per_tier,
    seeded_agent_name,
    split_agent_name,
)
from agents.policies.external import (
    external_env_settings,
    external_parameters,
    external_privileged,
    is_external_name,
)
from agents.policies.loading import load_policy_file, training_config_beside
from agents.policies.registry import is_built, requested_env_kwargs, rule_agent
from agents.policies.sb3_models import (
    is_sb3_model_name,
    sb3_model_env_settings,
    sb3_model_parameters,
)
from agents.policies.training_seeds import TrainingSeedsAgent
from agents.training.train_config import TrainConfig, tier_run_name
from flownav_env.tiers import TIER_NAMES

_SEED_FILE = re.compile(r"^seed_(\d+)\.zip$")

POLICY_OPTION_HELP = (
    "PPO policy .zip (default: the agent's shipped training seeds, results/policies/<agent>/seed_<k>.zip in "
    "the repository). Only its parameters are read, from the training config (.yaml) beside it; a zip without "
    "one is refused, since loading it would unpickle it and can run code (--trust-pickle allows that). A "
    "policy not listed with its hash in its folder's MANIFEST.sha256 loads with a warning"
)
"""The ``--policy`` help of every command that loads a policy, so each says what loading one risks."""

TRUST_PICKLE_HELP = (
    "load a --policy zip that has no training config beside it with PPO.load, which unpickles it and so runs "
    "any code it holds: only for a file you trust"
)
"""The ``--trust-pickle`` help of every command that takes ``--policy``."""


def policy_file(
    name: str,
    path: str | Path | None = None,
    directory: str | Path = POLICIES_DIR,
    *,
    tier: str | None = None,
) -> Path:
    """Where the learned agent ``name`` is stored: ``path`` if given, else ``<directory>/<agent>/seed_<k>.zip``
    for a training seed ``<agent>@<k>`` (``<directory>/<agent>_<tier>/seed_<k>.zip`` for an agent learned once
    per tier, :func:`policy_folder`); for an agent named alone, its first shipped training seed's file if it
    has any (where one file must stand for it: its env settings, a task's policy), else its single
    :func:`single_policy_file`. A per-tier agent's file without ``tier`` is that of the first tier, in suite
    order, that ships the seed: the tiers' recipe is one, so it stands for the others. The default directory
    is the repository's ``results/policies/``, whatever the current directory."""
    if path:
        return Path(path)
    agent, train_seed = split_agent_name(name)
    if train_seed is None:
        seeds = trained_seeds(agent, directory, tier=tier)
        if not seeds:
            return single_policy_file(agent, directory)
        train_seed = seeds[0]
    if is_per_tier(agent) and tier is None:
        tier = next(
            (t for t in TIER_NAMES if train_seed in trained_seeds(agent, directory, tier=t)), TIER_NAMES[0]
        )
    return policy_folder(agent, directory, tier=tier) / f"seed_{train_seed}.zip"


def policy_folder(agent: str, directory: str | Path = POLICIES_DIR, *, tier: str | None = None) -> Path:
    """The folder of the learned ``agent``'s shipped training seeds: ``<directory>/<agent>``, or for an agent
    learned once per tier, tier ``tier``'s run as ``flownav train --tiers <tier> --ship`` ships it
    (``<directory>/<agent>_<tier>``).

    Raises:
        ValueError: a per-tier agent without a tier, or a tier on an agent that is not per-tier.
    """
    if is_per_tier(agent) != (tier is not None):
        raise ValueError(
            f"{agent} is learned once per tier: name one of {', '.join(TIER_NAMES)}"
            if tier is None
            else f"{agent} has one policy for every tier, got tier {tier!r}"
        )
    return Path(directory) / (tier_run_name(agent, tier) if tier is not None else agent)


def single_policy_file(agent: str, directory: str | Path = POLICIES_DIR) -> Path:
    """``<directory>/<agent>.zip``: where an agent trained without training seeds keeps its one policy."""
    return Path(directory) / f"{agent}.zip"


def trained_seeds(
    agent: str, policies_dir: str | Path = POLICIES_DIR, *, tier: str | None = None
) -> list[int]:
    """The training seeds shipped for the learned ``agent``: ``<policies_dir>/<agent>/seed_<k>.zip``; for an
    agent learned once per tier, those of ``tier``, or with no tier those shipped on any tier."""
    if is_per_tier(agent) and tier is None:
        return sorted({seed for name in TIER_NAMES for seed in trained_seeds(agent, policies_dir, tier=name)})
    folder = policy_folder(agent, policies_dir, tier=tier)
    if not folder.is_dir():
        return []
    return sorted(int(m.group(1)) for p in folder.iterdir() if (m := _SEED_FILE.match(p.name)))


def shipped_seed_runs(agent: str, policies_dir: str | Path = POLICIES_DIR) -> list[str]:
    """The run names of the learned ``agent``'s shipped training seeds, in seed order: ``ppo_flow@0``, ..."""
    return [seeded_agent_name(agent, seed) for seed in trained_seeds(agent, policies_dir)]


def default_runs(agent: str, policies_dir: str | Path = POLICIES_DIR) -> tuple[list[str], str]:
    """The runs that fly when a learned ``agent`` is named without a training seed, and a line saying which:
    its shipped training seeds (``ppo_flow@0``, ...), else its single ``<agent>.zip``, else none.

    The single ``<agent>.zip`` is kept for agents trained before training seeds existed; where seeds are
    shipped it is not what the benchmark reports, so it only flies when named with ``--policy``.
    """
    names = shipped_seed_runs(agent, policies_dir)
    single = single_policy_file(agent, policies_dir)
    if names:
        seeds = ", ".join(str(split_agent_name(name)[1]) for name in names)
        where = Path(policies_dir) / (f"{agent}_<tier>" if is_per_tier(agent) else agent)
        return names, f"{agent}: training seeds {seeds} in turn over the layouts ({where}/seed_<k>.zip)"
    if single.exists():
        return [agent], (
            f"{agent}: no training seeds in {Path(policies_dir) / agent}/, flying the single policy {single}"
        )
    if is_per_tier(agent):
        return [], f"{agent}: no policy on any tier at {Path(policies_dir) / agent}_<tier>/seed_<k>.zip"
    return [], f"{agent}: no policy at {Path(policies_dir) / agent}/seed_<k>.zip or {single}"


def runs_to_fly(name: str, policy: str | Path | None = None) -> tuple[list[str], str | None]:
    """The runs a command flies for the agent ``name``, and a line saying which when it chose them: ``name``
    itself, unless it is a learned agent named without a training seed or a ``policy`` file; then its
    :func:`default_runs` in the repository's ``results/policies/``.

    Raises:
        ValueError: an unknown agent name.
        FileNotFoundError: a learned agent with neither shipped seeds nor a single policy.
    """
    agent, train_seed = split_agent_name(name)
    if not is_learned(agent) or train_seed is not None or policy is not None:
        return [name], None
    runs, message = default_runs(agent, POLICIES_DIR)
    if not runs:
        raise FileNotFoundError(f"nothing to fly for {message} (train it first: flownav train --seeds)")
    return runs, message


def agent_env_kwargs(name: str, path: str | Path | None = None) -> dict[str, Any]:
    """The env kwargs an agent must be evaluated with, whatever the sensor cell: for a learned agent, the
    ``env`` section of the training config saved beside its ``.zip`` (an oracle policy flies on oracle
    observations, a policy trained at another resolution keeps it); for a rule or a planner, what it reads
    beyond the defaults (its entry's ``env`` in ``configs/agents.yaml``:
    :func:`~agents.policies.registry.requested_env_kwargs`; the planners' privileged keys); empty when no config
    copy exists. A sweep cell's own kwargs go on top of these.
    """
    if is_sb3_model_name(name):
        return sb3_model_env_settings(name)
    if is_external_name(name):
        return dict(external_env_settings(name))
    if not is_learned(name):
        return dict(requested_env_kwargs(split_agent_name(name)[0]))
    config_path = policy_file(name, path).with_suffix(".yaml")
    if not config_path.is_file():
        return {}
    return dict(load_config(config_path, TrainConfig).env)


def trained_on(name: str, path: str | Path | None = None) -> str:
    """What the learned agent ``name`` trained on, from the training config beside its policy: the env id and
    the settings drawn per episode, e.g. ``FlowNav-v0, forward_speed 0.5-2.0 drawn per episode``; empty for an
    agent that did not learn or has no config beside its policy."""
    if is_sb3_model_name(name) or is_external_name(name) or not is_learned(name):
        return ""
    config_path = policy_file(name, path).with_suffix(".yaml")
    if not config_path.is_file():
        return ""
    config = load_config(config_path, TrainConfig)
    drawn = [
        f"{setting} {bounds[0]:g}-{bounds[1]:g}"
        for setting, bounds in config.randomize.ranges().items()
        if bounds
    ]
    return config.env_id + (f", {', '.join(drawn)} drawn per episode" if drawn else "")


def is_privileged(name: str) -> bool:
    """Whether the agent ``name`` is declared privileged (it may read what a tier's sensor does not give, and is
    a reference, never ranked): a declared agent that sees more than the tier's sensor (for a shipped one,
    :data:`~agents.policies.base.PRIVILEGED_AGENTS`), or an outside agent with ``privileged = True``. Reactive
    rules and stable-baselines3 model files never are."""
    if is_sb3_model_name(name):
        return False
    if is_external_name(name):
        return external_privileged(name)
    return AGENTS[split_agent_name(name)[0]].privileged


def load_agent(
    name: str,
    policy_path: str | Path | None = None,
    *,
    trust_pickle: bool = False,
    limits: AgentLimits | None = None,
    **bee_params: float,
) -> Agent:
    """The agent called ``name`` (see :data:`~agents.policies.base.AGENT_NAMES`).

    A learned agent named without a training seed or a ``policy_path`` is every training seed shipped in the
    repository's ``results/policies/<agent>/``, one per episode in turn
    (:class:`~agents.policies.training_seeds.TrainingSeedsAgent`), as the benchmark flies it; an agent without
    training seeds loads its single ``results/policies/<agent>.zip``.

    Args:
        name: agent name; ``<learned agent>@<k>`` for training seed k; ``module.path:callable`` or
            ``path/to/file.py:callable`` for an agent written outside FlowNav
            (:mod:`agents.policies.external`).
        policy_path: for PPO agents, the ``.zip`` to load instead of the shipped ones. Only its parameters
            are read, from the training config beside it; a policy its folder's ``MANIFEST.sha256`` does not
            vouch for loads with an :class:`UnverifiedPolicyWarning`.
        trust_pickle: load a zip without a training config beside it with ``PPO.load`` (unpickling, which
            runs any code in it); without this such a zip raises a ValueError.
        limits: the memory and CPU time an outside agent's process may use (default :class:`AgentLimits`'s).
        bee_params: overrides of a reactive agent's gains (its dataclass fields).

    An outside agent (a file, a module, a stable-baselines3 model zip) runs in a process of its own
    (:class:`~agents.policies.agent_process.IsolatedAgent`, one per name and options in this process); the
    agents FlowNav ships run here.

    Raises:
        ValueError: unknown name, a policy file that is not a readable policy or has no config beside it
            (unless ``trust_pickle``), or training seeds trained with different env settings; the message
            names the file.
        FileNotFoundError: a PPO policy file is missing.
    """
    base, train_seed = split_agent_name(name)
    if is_external_name(name):  # an SB3 model's name too
        agent = isolated_agent(name, trust_pickle=trust_pickle, limits=limits)
        agent.declarations()  # started now: one that does not load fails here
        return agent
    if is_built(name):
        return rule_agent(name, bee_params)
    if is_learned(name):
        if policy_path is None and train_seed is None:
            return _shipped_agent(base, trust_pickle)
        path = policy_file(name, policy_path)
        if not path.is_file():
            raise FileNotFoundError(f"policy file for agent {name!r} not found: {path} (train it first)")
        return load_policy_file(path, trust_pickle=trust_pickle)
    raise AssertionError(f"agent {base!r} is in AGENT_NAMES but has no constructor here")


def _shipped_agent(agent: str, trust_pickle: bool) -> Agent:
    if is_per_tier(agent):
        raise ValueError(
            f"{agent} is learned once per tier: flownav suite and score fly each tier's policies; elsewhere name "
            f"one with --policy {POLICIES_DIR}/{agent}_<tier>/seed_<k>.zip"
        )
    runs, message = default_runs(agent, POLICIES_DIR)
    if not runs:
        raise FileNotFoundError(f"nothing to fly for {message} (train it first: flownav train --seeds)")
    if runs == [agent]:  # no training seeds, a single policy
        return load_policy_file(single_policy_file(agent, POLICIES_DIR), trust_pickle=trust_pickle)
    files = {run: policy_file(run, directory=POLICIES_DIR) for run in runs}
    # One env serves every seed, so they must agree on it (agent_env_kwargs reads the first seed's).
    settings = {run: agent_env_kwargs(run, path) for run, path in files.items()}
    if len({repr(sorted(env.items())) for env in settings.values()}) > 1:
        raise ValueError(
            f"the training seeds of {agent} in {POLICIES_DIR / agent}/ were trained with different env "
            f"settings ({settings}): name one, such as {runs[0]}"
        )
    return TrainingSeedsAgent(
        [(run, load_policy_file(path, trust_pickle=trust_pickle)) for run, path in files.items()]
    )


def agent_parameters(name: str, **overrides: float) -> dict[str, object]:
    """Every parameter the agent ``name`` flies with: a reactive agent's dataclass fields, its defaults with
    ``overrides`` on top; for a learned agent just ``overrides`` (its parameters are its policy file, which
    episode records identify by hash). Episode records keep these, so episodes flown before a reactive
    agent's defaults were re-tuned never count as the re-tuned agent's.

    Raises:
        ValueError: an unknown agent, or an override the agent does not have.
    """
    if is_learned(name):
        return dict(overrides)
    if is_sb3_model_name(name):
        return {**sb3_model_parameters(name), **overrides}
    if is_external_name(name):
        return {**external_parameters(name), **overrides}
    try:
        agent = rule_agent(name, overrides)
    except TypeError as error:  # an unknown field: the dataclass names it
        raise ValueError(f"agent {name!r} has no such parameter: {error}") from None
    return dataclasses.asdict(agent)


@dataclass(frozen=True)
class LoadedPolicy:
    """A trained policy with the env it was trained for: build that env with :meth:`make_env` (or
    ``gym.make(env_id, **env_kwargs)``); ``gym.make("FlowNav-v0")`` alone would miss settings such as an
    oracle policy's ``obs_source``."""

    agent: Agent
    env_id: str
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    path: Path | None = None

    def make_env(self, **overrides: object) -> gym.Env:
        """The env the policy was trained for, with ``overrides`` (a sensor error, ``render_mode``) on top."""
        return gym.make(self.env_id, **{**self.env_kwargs, **overrides})


def load_policy(path: str | Path) -> LoadedPolicy:
    """The policy in ``path`` with its env id and env settings, from the training config saved beside it.

    Raises:
        FileNotFoundError: no such file, or no training config beside it (its env would be unknown).
        ValueError: not a readable policy, or an invalid config; the message names the file.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"policy file not found: {path}")
    config = training_config_beside(path)
    if config is None:
        raise FileNotFoundError(
            f"no training config beside {path} (expected {path.with_suffix('.yaml')}): the env it was "
            "trained for is unknown"
        )
    return LoadedPolicy(load_policy_file(path), config.env_id, dict(config.env), path)
