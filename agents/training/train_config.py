"""A training run's YAML, as typed dataclasses: the PPO hyperparameters, the per-episode sensor
randomisation and the run itself (``configs/ppo_*.yaml``)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields, make_dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from agents.common.seeds import MAX_RUN_SEED
from agents.common.yaml_config import Bounds, checked_field, field_range, from_mapping, interval, within
from flownav_env.privileged import PRIVILEGED_KEYS
from flownav_env.settings import COURSE_FIELDS, SENSOR_FIELDS
from flownav_env.settings_check import setting_check
from flownav_env.tiers import TIERS_BY_VERSION, tier, tier_of_env_id


@dataclass
class PPOParams:
    """stable-baselines3 PPO hyperparameters (see its docs); ``net_arch`` sizes both actor and critic."""

    learning_rate: float = field_range(1e-6, 1.0, default=3e-4)
    n_steps: int = field_range(8, 100_000, default=512)
    batch_size: int = field_range(8, 100_000, default=256)
    n_epochs: int = field_range(1, 100, default=10)
    gamma: float = field_range(0.0, 1.0, default=0.99)
    gae_lambda: float = field_range(0.0, 1.0, default=0.95)
    clip_range: float = field_range(0.01, 1.0, default=0.2)
    ent_coef: float = field_range(0.0, 1.0, default=0.0)
    net_arch: list[int] = field_range(1, 4096, default_factory=lambda: [64, 64])
    # Initial log standard deviation of the Gaussian actions: 0 (std 1) on a [-1, 1] action box is mostly
    # clipped, bang-bang exploration that crashes early; lower starts calmer.
    log_std_init: float = field_range(-5.0, 2.0, default=0.0)
    # 0: a feed-forward policy (PPO). Above 0: an LSTM of this many units after the shared features
    # (sb3-contrib's RecurrentPPO), so the policy can remember what left the view.
    lstm_hidden_size: int = field_range(0, 1024, default=0)


@dataclass
class ImitationParams:
    """A teacher start before PPO (:mod:`agents.training.imitation`): DAgger rounds against a teacher agent;
    an empty ``teacher`` skips it."""

    # An agent name (``bee_ttc``); its observation keys must be in the config's ``env``. A privileged teacher
    # (``planner``) brings its own opt-in (observe_layout), given to the training envs only, never to ``env``.
    teacher: str = ""
    rounds: int = field_range(1, 100, default=3)
    steps_per_round: int = field_range(1, 1_000_000, default=8192)  # per env
    epochs: int = field_range(1, 1000, default=10)
    batch_size: int = field_range(8, 100_000, default=256)
    learning_rate: float = field_range(1e-6, 1.0, default=1e-3)
    value_weight: float = field_range(0.0, 100.0, default=0.5)
    # The planner teacher's own parameters (fields of agents.policies.planner.PlannerAgent), e.g. wider margins
    # than the reference flies so that a student's imitation error has room; empty = the reference planner.
    teacher_params: dict[str, float] = field(default_factory=dict)


# What training may draw afresh each episode: every sensor setting the env declares and the course's speed and
# density (flownav_env.settings), so a sensor setting the env gains is one training can vary without an edit here.
RANDOMIZED_FIELDS = SENSOR_FIELDS + COURSE_FIELDS


class RandomizationRanges:
    """Per-episode uniform ranges [low, high] of the sensor and course variables; empty = fixed. The fields, one
    per name of :data:`RANDOMIZED_FIELDS`, each a ``list[float]`` checked against the env's rule for its setting,
    are made by :func:`_randomization_class`."""

    def ranges(self) -> dict[str, list[float]]:
        """Every variable's range, by name (an empty list where it is fixed)."""
        return {name: list(getattr(self, name)) for name in RANDOMIZED_FIELDS}

    def validate(self) -> None:
        for name, bounds in self.ranges().items():
            if bounds and (len(bounds) != 2 or bounds[0] > bounds[1]):
                raise ValueError(f"key 'randomize.{name}' must be [low, high] with low <= high, got {bounds}")


def _randomization_class() -> type[RandomizationRanges]:
    """The dataclass of :class:`RandomizationRanges` with a field for each name of :data:`RANDOMIZED_FIELDS`."""
    fields_ = [
        (name, list[float], checked_field(setting_check(name), default_factory=list))
        for name in RANDOMIZED_FIELDS
    ]
    made = make_dataclass("Randomization", fields_, bases=(RandomizationRanges,))
    made.__module__ = __name__
    made.__doc__ = RandomizationRanges.__doc__
    return made


if TYPE_CHECKING:
    Randomization = RandomizationRanges
else:
    Randomization = _randomization_class()


@dataclass
class TrainConfig:
    """A training run. Every key of the YAML file maps to a field here."""

    name: str
    env_id: str = "FlowNav-v0"
    # One recipe for every tier of the suite version ``env_id`` belongs to: each run names its tier
    # (``flownav train --tier hard``), flies that tier's id and is named ``<name>_<tier>`` (:func:`for_tier`).
    per_tier: bool = False
    env: dict[str, Any] = field(default_factory=dict)
    randomize: Randomization = field(default_factory=Randomization)
    total_timesteps: int = field_range(1, 100_000_000, default=400_000)
    n_envs: int = field_range(1, 64, default=2)
    seed: int = field_range(0, MAX_RUN_SEED, default=0)  # the run's seed: PPO's and its env workers'
    max_minutes: float = field_range(0.1, 10_000.0, default=60.0)
    checkpoint_every: int = field_range(1, 100_000_000, default=20_000)
    eval_every: int = field_range(1, 100_000_000, default=20_000)
    eval_episodes: int = field_range(1, 1000, default=10)
    # Memory by frame stacking (SB3's VecFrameStack): the policy sees the observations of the last
    # ``frame_stack`` frames, each array stacked along its last axis; 1 = the current frame only.
    frame_stack: int = field_range(1, 16, default=1)
    # A curriculum's later stage starts from an earlier stage's policy: a model zip, where ``{seed}`` stands
    # for this run's seed (``results/policies/ppo_flow/seed_{seed}.zip``); empty = random initial weights.
    # Only the policy's weights carry over: the optimiser, step count and evaluations start afresh.
    init_from: str = ""
    imitation: ImitationParams = field(default_factory=ImitationParams)
    ppo: PPOParams = field(default_factory=PPOParams)

    def validate(self) -> None:
        """The rules between keys (each key's own range is on its field); ValueError names the keys."""
        if self.init_from:
            try:
                self.init_from.format(seed=0)
            except (KeyError, IndexError, ValueError) as error:
                raise ValueError(
                    f"key 'init_from' may hold only the placeholder {{seed}}, got {self.init_from!r} ({error})"
                ) from error
        if self.per_tier and tier_of_env_id(self.env_id) is None:
            raise ValueError(
                f"key 'per_tier' needs 'env_id' to be a suite tier's id (it picks the suite version), got "
                f"{self.env_id!r}"
            )
        if self.imitation.teacher:
            self._check_teacher()
        if self.frame_stack > 1 and self.ppo.lstm_hidden_size > 0:
            raise ValueError(
                f"keys 'frame_stack' ({self.frame_stack}) and 'ppo.lstm_hidden_size' ({self.ppo.lstm_hidden_size}) "
                "are two kinds of memory: use one (frame_stack: 1 or lstm_hidden_size: 0)"
            )

    def _check_teacher(self) -> None:
        # DAgger fits a feed-forward policy's actions state by state; memory comes from 'frame_stack', whose
        # stacks the student is fitted on while the teacher labels the current frame.
        if self.init_from or self.ppo.lstm_hidden_size > 0:
            raise ValueError(
                f"key 'imitation.teacher' ({self.imitation.teacher!r}) starts a feed-forward policy from scratch: "
                "it takes no 'init_from' or 'ppo.lstm_hidden_size' above 0 (for memory, use 'frame_stack')"
            )
        if self.env.get("observe_layout"):
            raise ValueError(
                f"key 'env.observe_layout' would show the student of teacher {self.imitation.teacher!r} the "
                f"privileged keys ({', '.join(PRIVILEGED_KEYS)}): remove it; a privileged teacher gets them alone"
            )


def tier_run_name(name: str, tier_name: str) -> str:
    """The run (and shipped agent) name of per-tier recipe ``name`` trained for tier ``tier_name``."""
    return f"{name}_{tier_name}"


def for_tier(config: TrainConfig, tier_name: str | None, source: str) -> TrainConfig:
    """The run a config asks for on ``tier_name`` (None: none named): a per-tier recipe (``per_tier: true``)
    becomes that tier's config of the recipe's suite version, its id flown and its name
    :func:`tier_run_name`; any other config is returned as it is, and takes no tier.

    Raises:
        ValueError: a per-tier recipe with no tier, a tier for a config that is not one, or an unknown tier;
            the message names ``source`` and the value.
    """
    if not config.per_tier:
        if tier_name is not None:
            raise ValueError(
                f"{source}: --tier {tier_name} needs a recipe with 'per_tier: true'; this config flies "
                f"{config.env_id} only"
            )
        return config
    found = tier_of_env_id(config.env_id)
    if found is None:  # validate() refuses it; kept for configs built in code
        raise ValueError(f"{source}: key 'per_tier' needs a suite tier's 'env_id', got {config.env_id!r}")
    if tier_name is None:
        raise ValueError(
            f"{source}: a recipe for every tier ('per_tier: true') needs --tier, one of "
            f"{', '.join(TIERS_BY_VERSION[found[0]])}"
        )
    try:
        spec = tier(tier_name, found[0])
    except ValueError as error:
        raise ValueError(f"{source}: --tier: {error}") from error
    return replace(config, name=tier_run_name(config.name, tier_name), env_id=spec.env_id, per_tier=False)


def init_source(config: TrainConfig) -> Path | None:
    """The model zip ``config.init_from`` names for the run's seed, or None for random initial weights."""
    return Path(config.init_from.format(seed=config.seed)) if config.init_from else None


def checked_config(config: TrainConfig, source: str) -> TrainConfig:
    """``config`` validated again as if loaded from a file, for values set after loading (command-line
    overrides, code); returns the validated copy.

    Raises:
        ConfigError (a ValueError): a value outside its field's range, naming ``source`` and the key.
    """
    return from_mapping(asdict(config), TrainConfig, source=source)


def field_bounds(name: str) -> Bounds:
    """The [low, high] range declared on the TrainConfig field ``name``, for messages about overrides."""
    (match,) = [f for f in fields(TrainConfig) if f.name == name]
    return match.metadata["range"]


def override(config: TrainConfig, name: str, value: float | None, option: str) -> None:
    """Set ``config.<name>`` from the command-line ``option`` when given, checked against the field's range.

    Raises:
        ValueError: ``value`` outside the range; the message names the option and the range.
    """
    if value is None:
        return
    bounds = field_bounds(name)
    if not within(value, bounds):
        raise ValueError(f"{option} must be in {interval(bounds)} (the config's {name} range), got {value}")
    setattr(config, name, value)


def rollout_note(config: TrainConfig, steps_done: int) -> str | None:
    """The line that says how far learning really goes when it is not ``total_timesteps``, else None.

    PPO learns from whole rollouts of ``n_steps × n_envs`` steps, so it trains on to the end of the rollout
    that reaches ``total_timesteps``: a budget below one rollout still trains a whole one.

    Args:
        config: the run's config.
        steps_done: the steps already trained (a resumed run's count), from which the rollouts are counted.

    Returns:
        One line naming the budget, the rollout and the steps it will train, or None when they agree.
    """
    rollout = config.ppo.n_steps * config.n_envs
    remaining = config.total_timesteps - steps_done
    if remaining <= 0 or remaining % rollout == 0:
        return None
    end = steps_done + -(-remaining // rollout) * rollout
    relation = "is less than one rollout" if remaining < rollout else "is not a whole number of rollouts"
    resumed = f" after the resumed {steps_done:,}" if steps_done else ""
    return (
        f"total_timesteps {config.total_timesteps:,} {relation} of {rollout:,} steps (n_steps "
        f"{config.ppo.n_steps} × n_envs {config.n_envs}){resumed}: training {'to ' if steps_done else ''}{end:,}"
    )
