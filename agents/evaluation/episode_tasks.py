"""Which episodes a run is made of, and which of them a CSV already holds.

A task names an agent, a sensor factor and its level, and a seed. Every record is stamped with its task's
identity (env id, full env settings, agent parameters, policy hash); a resumed run skips only episodes flown
with the same identity and refuses a CSV whose rows were flown with other settings under the same (agent,
factor, level, seed). Flying the tasks is :mod:`agents.evaluation.runner`'s job.
"""

from __future__ import annotations

import functools
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypedDict

from agents.analysis.csv_file import move_aside
from agents.analysis.episode_record import EpisodeRow, PooledRow
from agents.analysis.records import (
    FRESH_FILE_HINT,
    IDENTITY_FIELDS,
    episode_key,
    predates_identities,
    read_episodes,
    row_identity,
    suite_version_of,
)
from agents.analysis.statistics import RUN_KEY
from agents.common.locations import POLICIES_DIR
from agents.common.manifest import file_sha256
from agents.policies import (
    agent_env_kwargs,
    agent_parameters,
    is_learned,
    is_per_tier,
    policy_file,
    split_agent_name,
)
from agents.policies.agent_limits import AgentLimits
from flownav_env.tiers import tier_of_env_id


def canonical_json(value: object) -> str:
    """``value`` as JSON with sorted keys and no spaces: equal settings give equal text."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"), default=str)


def cached_file_sha256(path: Path) -> str:
    """:func:`~agents.common.manifest.file_sha256` of the file ("" if there is none), cached while its size
    and mtime stay the same: every episode record carries its policy's hash."""
    try:
        stat = path.stat()
    except OSError:
        return ""
    return _sha256_of_version(str(path.resolve()), stat.st_mtime_ns, stat.st_size)


@functools.cache
def _sha256_of_version(path: str, mtime_ns: int, size: int) -> str:
    """The hash of ``path`` as it is at this mtime and size (the two name the file's version, so the result
    is fixed by the arguments)."""
    return file_sha256(Path(path))


class EpisodeIdentity(TypedDict):
    """What defines an episode beyond its (agent, factor, level, seed): the
    :data:`~agents.analysis.records.IDENTITY_FIELDS` its record carries."""

    env_id: str
    env_kwargs: str
    agent_params: str
    policy_sha256: str


def record_label(env_kwargs: Mapping[str, object]) -> tuple[str, float]:
    """(factor, level) of the records flown with ``env_kwargs``: ``clean`` for defaults, the kwarg and its value
    for one numeric setting (as in the sweep), else every setting spelled out, so different settings never share
    a row key."""
    if not env_kwargs:
        return "clean", 0.0
    if len(env_kwargs) == 1:
        ((key, value),) = env_kwargs.items()
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return key, float(value)
    return ",".join(f"{k}={env_kwargs[k]}" for k in sorted(env_kwargs)), 0.0


@dataclass(frozen=True)
class EpisodeTask:
    """One episode to fly: who, with which env kwargs, from which seed; ``factor``/``level`` label the record."""

    agent: str
    factor: str
    level: float
    seed: int
    env_id: str = "FlowNav-v0"
    env_kwargs: tuple[tuple[str, Any], ...] = ()
    policy: str | None = None  # a learned agent's .zip; None: its file in <repo>/results/policies/
    bee_params: tuple[tuple[str, float], ...] = field(default=())
    # Load a policy zip without its config by unpickling it (runs its code): the user's explicit opt-in.
    trust_pickle: bool = False
    # The suite version its record carries (flownav_env.tiers.SUITE_VERSION) when it is an episode of the suite.
    suite_version: str = ""
    # The most an outside agent's predict may take per call (0: no limit); how it flies, not which episode.
    step_timeout_s: float = 0.0
    # The memory and CPU time an outside agent's process may use; how it flies, not which episode.
    agent_limits: AgentLimits = field(default_factory=AgentLimits)
    # An outside agent's settings (canonical JSON) where the run was planned: where the episode flies, the
    # agent's process must declare the same ("" where nothing was planned).
    planned_settings: str = ""

    @property
    def tier(self) -> str:
        """The suite tier this episode is on ("" outside the suite); see :func:`suite_task`."""
        return self.factor if self.suite_version else ""

    def policy_path(self) -> Path | None:
        """The learned agent's policy file (wherever the command runs from); None for reactive agents. An agent
        learned once per tier flies the policy of the tier whose id the task flies.

        Raises:
            ValueError: an agent learned once per tier, without a policy file, on an id that is no tier's.
        """
        if not is_learned(self.agent):
            return None
        tier_name = None
        if self.policy is None and is_per_tier(self.agent):
            found = tier_of_env_id(self.env_id)
            if found is None:
                raise ValueError(
                    f"{self.agent} is learned once per tier: fly it on a suite tier (--tiers clean, hard, noisy or "
                    f"hard_noisy), or name one of its policies with --policy; got {self.env_id!r}"
                )
            tier_name = found[1].name
        return policy_file(self.agent, self.policy, directory=POLICIES_DIR, tier=tier_name)

    def env_settings(self) -> dict[str, Any]:
        """The env kwargs to fly with: the agent's own (a learned agent keeps what it was trained with, such
        as oracle observations), then this task's on top."""
        return {**agent_env_kwargs(self.agent, self.policy_path()), **dict(self.env_kwargs)}

    def identity(self) -> EpisodeIdentity:
        """What defines this task's episode beyond its (agent, factor, level, seed)."""
        policy = self.policy_path()
        return {
            "env_id": self.env_id,
            "env_kwargs": canonical_json(self.env_settings()),
            "agent_params": canonical_json(agent_parameters(self.agent, **dict(self.bee_params))),
            "policy_sha256": "" if policy is None else cached_file_sha256(policy),
        }


# The episodes CSV has no tier column: a suite episode keeps its tier in the factor column, at level SUITE_LEVEL,
# so that it is keyed, resumed and stored like any other episode. suite_task writes that, with_tier reads it.
SUITE_LEVEL = 0.0


def suite_task(
    run: str,
    tier_name: str,
    seed: int,
    *,
    env_id: str,
    settings: Mapping[str, object],
    suite_version: str,
    policy: str | None = None,
    trust_pickle: bool = False,
) -> EpisodeTask:
    """The episode of ``run`` on the suite tier ``tier_name`` (its ``env_id`` and ``settings``) from layout
    ``seed``, stamped with ``suite_version``."""
    return EpisodeTask(
        run,
        tier_name,
        SUITE_LEVEL,
        seed,
        env_id,
        tuple((name, settings[name]) for name in sorted(settings)),
        policy,
        trust_pickle=trust_pickle,
        suite_version=suite_version,
    )


class TieredRow(EpisodeRow):
    """A suite episode's row with its tier under its own key (:func:`with_tier`)."""

    tier: str


def with_tier(row: EpisodeRow) -> TieredRow:
    """A suite episode's row with its tier under its own key, ``tier``."""
    return {**row, "tier": row["factor"]}


def _identities(tasks: list[EpisodeTask]) -> list[tuple[str, ...]]:
    """Each task's identity as a tuple in IDENTITY_FIELDS order, computed once per distinct setting (a sweep
    has thousands of tasks but only agents × cells settings, and a learned agent's reads files)."""
    cache: dict[str, tuple[str, ...]] = {}
    result = []
    for task in tasks:
        setting = canonical_json([task.agent, task.env_id, task.env_kwargs, task.policy, task.bee_params])
        if setting not in cache:
            identity = task.identity()
            cache[setting] = tuple(identity[name] for name in IDENTITY_FIELDS)
        result.append(cache[setting])
    return result


@dataclass
class ResumePlan:
    """What a CSV holds of a run's tasks: those still to fly (``todo``), how many are there already
    (``done``), how many of its lines were damaged (``damaged``: torn or failing their checksum, so their
    episodes count as not flown), and the rows of these episodes flown under another suite version
    (``other_versions``: version → rows; left out, never counted as current)."""

    todo: list[EpisodeTask]
    done: int = 0
    damaged: int = 0
    other_versions: dict[str, int] = field(default_factory=dict)


def resume_plan(tasks: list[EpisodeTask], csv_path: Path, remedy: str = FRESH_FILE_HINT) -> ResumePlan:
    """Which of ``tasks`` the CSV at ``csv_path`` already holds, and what it holds that does not count.

    Args:
        remedy: what the command offers when the CSV cannot be resumed (:data:`FRESH_FILE_HINT`, or
            :data:`~agents.analysis.records.OVERWRITE_HINT` where it has ``--overwrite``).

    Raises:
        ValueError: the CSV predates episode identities, or holds an episode of one of the tasks flown with
            other settings under the same suite version (resuming would mix the two), or two tasks share a
            key but not their settings.
    """
    csv_path = Path(csv_path)
    episodes = read_episodes(csv_path)
    if episodes.legacy:
        raise ValueError(predates_identities(csv_path, remedy))
    identities = _identities(tasks)
    wanted: dict[tuple, tuple[str, ...]] = {}
    versions: dict[tuple, str] = {}
    for task, identity in zip(tasks, identities, strict=True):
        key = episode_key(vars(task))
        if wanted.setdefault(key, identity) != identity:
            raise ValueError(f"two tasks are episode {_describe(key)} but with different settings")
        versions[key] = task.suite_version
    plan = ResumePlan([], damaged=episodes.skipped)
    flown: dict[tuple, set[tuple[str, ...] | None]] = {}
    for row in episodes.rows:
        key = episode_key(row)
        if key in versions and suite_version_of(row) != versions[key]:
            version = suite_version_of(row) or "none"
            plan.other_versions[version] = plan.other_versions.get(version, 0) + 1
            continue
        flown.setdefault(key, set()).add(row_identity(row))
    for task, identity in zip(tasks, identities, strict=True):
        found = flown.get(episode_key(vars(task)), set())
        if identity in found:
            plan.done += 1
            continue
        if found:
            raise ValueError(_conflict(csv_path, episode_key(vars(task)), identity, found, remedy))
        plan.todo.append(task)
    return plan


def pending_tasks(
    tasks: list[EpisodeTask], csv_path: Path, remedy: str = FRESH_FILE_HINT
) -> list[EpisodeTask]:
    """The tasks whose episode is not in the CSV yet (what a resumed run still has to fly).

    Raises:
        ValueError: as :func:`resume_plan`.
    """
    return resume_plan(tasks, csv_path, remedy).todo


def set_aside_stale_episodes(tasks: list[EpisodeTask], csv_path: Path, why: str) -> Path | None:
    """Move ``csv_path`` aside (``<name>.bak-<time>``) when it holds an episode of one of ``tasks`` flown with
    other settings, and say so with ``why``; returns where it went, or None when nothing was stale.

    For episodes that only ever stand for the current code's agent (a re-tuned reactive reference, a run's
    current finalists), where :func:`pending_tasks` would refuse to mix them. Nothing is deleted.
    """
    csv_path = Path(csv_path)
    if not csv_path.is_file():
        return None
    wanted = {
        episode_key(vars(task)): identity for task, identity in zip(tasks, _identities(tasks), strict=True)
    }
    stale = sorted(
        {
            str(row["agent"])
            for row in read_episodes(csv_path).rows
            if episode_key(row) in wanted and row_identity(row) != wanted[episode_key(row)]
        }
    )
    if not stale:
        return None
    backup = move_aside(csv_path)
    print(
        f"{csv_path} holds episodes of {', '.join(stale)} flown with other settings ({why}); moved to {backup}"
    )
    return backup


def _describe(key: tuple[str, str, float, int]) -> str:
    agent, factor, level, seed = key
    return f"({agent}, {factor}, level {level:g}, seed {seed})"


def _conflict(path: Path, key: tuple, identity: tuple[str, ...], found: set, remedy: str) -> str:
    there = next(iter(found))
    changed = [
        (name, old, new)
        for name, old, new in zip(IDENTITY_FIELDS, there or (None,) * len(identity), identity, strict=True)
        if old != new
    ]
    causes = [cause for name, old, new in changed if (cause := _edited_file(name, old, new))]
    differences = ", ".join(causes) or ", ".join(
        f"{name} {old!r} there, {new!r} now" for name, old, new in changed
    )
    return (
        f"{path} already holds episode {_describe(key)} flown with other settings ({differences}); "
        f"resuming would mix them. To fly these settings, {remedy}"
    )


def _edited_file(name: str, old: str | None, new: str) -> str:
    """The plain cause when an identity field differs because a file changed, an outside agent's source (its
    ``source_sha256`` in ``agent_params``) or a learned agent's policy, with the two hashes cut short; else
    ""."""
    if name == "policy_sha256" and old:
        return f"the policy file changed since these episodes were flown: policy_sha256 {old[:12]} there, {new[:12]} now"
    if name != "agent_params" or old is None:
        return ""
    try:
        before, after = json.loads(old), json.loads(new)
    except json.JSONDecodeError:
        return ""
    if not (isinstance(before, dict) and isinstance(after, dict)) or set(before) != set(after):
        return ""
    if set(before) != {"source_sha256"} or before == after:
        return ""
    return (
        "your agent's file changed since these episodes were flown: source_sha256 "
        f"{before['source_sha256'][:12]} there, {after['source_sha256'][:12]} now"
    )


def pooled_over_training_seeds(rows: Sequence[EpisodeRow]) -> list[PooledRow]:
    """Rows with each learned agent's training seeds (``ppo_flow@3``) relabelled as the agent, so that a
    summary gives the agent one row over its seeds."""
    pooled: list[PooledRow] = [
        {**row, "agent": split_agent_name(row["agent"])[0], RUN_KEY: row["agent"]} for row in rows
    ]
    return pooled


def rows_of(tasks: list[EpisodeTask], rows: Sequence[EpisodeRow]) -> list[EpisodeRow]:
    """The rows that are episodes of ``tasks``: same (agent, factor, level, seed), suite version and identity,
    or an unknown identity (a CSV from before identities), so a report never mixes in episodes of other
    settings or another suite version."""
    wanted = {
        episode_key(vars(task)): identity for task, identity in zip(tasks, _identities(tasks), strict=True)
    }
    versions = {episode_key(vars(task)): task.suite_version for task in tasks}
    return [
        row
        for row in rows
        if episode_key(row) in wanted
        and row_identity(row) in (None, wanted[episode_key(row)])
        and suite_version_of(row) == versions[episode_key(row)]
    ]
