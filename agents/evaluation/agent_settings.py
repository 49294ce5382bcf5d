"""An outside agent's env settings: declared where a run is planned, checked again where each episode flies (its
own process could declare otherwise there), and what the record keeps."""

from __future__ import annotations

import dataclasses
from typing import Any

from agents.evaluation.episode_tasks import EpisodeTask, canonical_json
from agents.policies import Agent
from agents.policies.agent_process import IsolatedAgent
from agents.policies.external import is_external_name
from agents.policies.sb3_models import is_sb3_model_name
from flownav_env.tiers import check_agent_settings


def flown_settings(task: EpisodeTask, agent: Agent) -> dict[str, Any]:
    """The env settings ``task`` flies with: for an outside agent, what its own process declares (plain values
    only), checked here, where the episode flies, against the tier and against what the run planned with.

    Raises:
        ValueError: one line naming the agent and the episode: settings a tier fixes, privileged data for an
            agent not declared privileged, or settings other than those the run was planned with.
    """
    if not isinstance(agent, IsolatedAgent) or is_sb3_model_name(task.agent):
        return task.env_settings()
    declared = agent.declarations()
    if task.tier:
        check_agent_settings(
            task.agent,
            declared.env_settings,
            task.tier,
            privileged=declared.privileged,
            version=task.suite_version,
        )
    settings = {**declared.env_settings, **dict(task.env_kwargs)}
    if task.planned_settings and canonical_json(settings) != task.planned_settings:
        raise ValueError(
            f"agent {task.agent} declares env settings {canonical_json(settings)} in the process that flies "
            f"{episode_name(task)}, but {task.planned_settings} where the run was planned: an agent's "
            "env_settings must be the same in every process; nothing was recorded of that episode"
        )
    return settings


def plan_settings(tasks: list[EpisodeTask]) -> list[EpisodeTask]:
    """``tasks`` with each outside agent's settings as declared here (``planned_settings``), for the process that
    flies each to check against (:func:`flown_settings`)."""
    planned: dict[tuple[str, tuple[tuple[str, Any], ...]], str] = {}
    result = []
    for task in tasks:
        if is_external_name(task.agent) and not is_sb3_model_name(task.agent):
            key = (task.agent, task.env_kwargs)
            if key not in planned:
                planned[key] = canonical_json(task.env_settings())
            task = dataclasses.replace(task, planned_settings=planned[key])
        result.append(task)
    return result


def episode_name(task: EpisodeTask) -> str:
    """The episode in words: a suite's tier and layout, or another run's factor, level and seed."""
    if task.tier:
        return f"the episode on tier {task.tier}, layout seed {task.seed}"
    return f"the episode ({task.factor}, level {task.level:g}, seed {task.seed})"
