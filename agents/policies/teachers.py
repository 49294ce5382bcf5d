"""Teachers for a run's teacher start (``imitation.teacher`` in a training config): which agents may teach, and
the check that the run's env observes everything the teacher reads.

A reactive rule reads the student's own observation, so the config's ``env`` must give it every key. A
privileged planner (any of :data:`~agents.policies.base.PLANNERS`: ``planner`` reads the layout and true state,
``planner_camera`` besides the camera's pose and the histogram's bins) declares its own opt-in
(:attr:`PlannerTeacher.privileged_settings`, the privileged part of the env settings it is flown with), the
training envs get it, and the student never sees its keys (:mod:`agents.training.student_view`), so the
config's ``env`` stays that of an ordinary agent.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import fields
from typing import Any, cast

import numpy as np

from agents.policies.base import PLANNERS, REACTIVE_AGENTS, Agent
from agents.policies.learned import agent_env_kwargs, load_agent
from agents.policies.planner import PlannerAgent
from agents.policies.registry import planner_class
from flownav_env.tiers import privileged_requests

TEACHERS = REACTIVE_AGENTS + PLANNERS


class PlannerTeacher:
    """A planner (``planner`` unless ``name`` says which of :data:`~agents.policies.base.PLANNERS`) over a batch
    of envs: one agent per env, since each plans its own episode's course and keeps that plan between steps.
    Its :attr:`privileged_settings` are the privileged env settings that planner is flown with, whichever it is.

    Raises:
        ValueError: ``name`` is not a planner, or ``params`` are not its parameters.
    """

    def __init__(self, params: Mapping[str, float] | None = None, name: str = "planner") -> None:
        if name not in PLANNERS:
            raise ValueError(f"a planner teacher must be one of {', '.join(PLANNERS)}, got {name!r}")
        self.name = name
        self.params = dict(params or {})
        self.planner_class = planner_class(name)
        # Its own opt-in, so that a planner reading more keys than the map's brings them to the training envs.
        self.privileged_settings: Mapping[str, object] = privileged_requests(agent_env_kwargs(name))
        self.planners: list[PlannerAgent] = []
        self._planner()  # checks the parameters now, not at the first step

    def predict(
        self,
        observation: dict[str, np.ndarray],
        state: object = None,
        episode_start: np.ndarray | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, object]:
        count = len(next(iter(observation.values())))
        while len(self.planners) < count:
            self.planners.append(self._planner())
        starts = np.ones(count, bool) if episode_start is None else np.asarray(episode_start, bool)
        actions = [
            planner.predict(
                {key: value[i : i + 1] for key, value in observation.items()},
                episode_start=starts[i : i + 1],
            )[0]
            for i, planner in enumerate(self.planners[:count])
        ]
        return np.stack(actions), state

    def _planner(self) -> PlannerAgent:
        return self.planner_class(**_planner_arguments(self.params))


def _planner_arguments(params: Mapping[str, float]) -> dict[str, Any]:
    """``params`` as a planner's keyword arguments: a number for each field, an integer or a switch where the
    field is one (:func:`check_teacher_params` checks each value's kind, the planner its range)."""
    return cast("dict[str, Any]", dict(params))


def check_teacher(
    name: str, env: Mapping[str, object], source: str, params: Mapping[str, float] | None = None
) -> None:
    """Check that ``name`` can teach a run whose env is made with ``env`` (a config's ``env`` section), with its
    own parameters ``params`` (a config's ``imitation.teacher_params``).

    Raises:
        ValueError: ``name`` is neither a reactive agent nor a planner (a teacher acts from the observation
            alone, so learned policies, which need their own env settings, are not offered), the env lacks
            a setting the teacher reads, or ``params`` are not the teacher's; the message names the key and the
            config file ``source``.
    """
    if name not in TEACHERS:
        raise ValueError(
            f"{source}: key 'imitation.teacher' must be one of {', '.join(TEACHERS)}, got {name!r}"
        )
    check_teacher_params(name, params or {}, source)
    wanted = agent_env_kwargs(name)
    # A privileged teacher's own opt-in is given to the training envs by the teacher start, not by 'env'.
    for setting, value in wanted.items():
        if setting not in privileged_requests(wanted) and _comparable(env.get(setting)) != _comparable(value):
            raise ValueError(
                f"{source}: the teacher {name!r} reads what the env setting {setting}={value!r} gives; add it "
                f"to the config's 'env' section (it has {setting}={env.get(setting)!r})"
            )


def _comparable(value: object) -> object:
    """A setting as compared with another: a YAML list and a declared tuple of the same numbers are equal."""
    return tuple(value) if isinstance(value, list | tuple) else value


def check_teacher_params(name: str, params: Mapping[str, float], source: str) -> None:
    """Raise ValueError unless ``params`` are parameters of teacher ``name``: that planner's own fields (the
    camera-limited ones add ``view_range`` and ``memory`` to the map planner's), each a number (an integer where
    the field counts, true or false for a switch) in its range; a rule flies its shipped gains and takes none."""
    if params and name not in PLANNERS:
        raise ValueError(
            f"{source}: key 'imitation.teacher_params' sets a planner teacher's parameters; {name!r} flies its "
            f"shipped gains and takes none, got {sorted(params)}"
        )
    if name not in PLANNERS:
        return
    planner = planner_class(name)
    defaults = {item.name: item.default for item in fields(planner)}
    for key, value in params.items():
        if key not in defaults:
            raise ValueError(
                f"{source}: key 'imitation.teacher_params.{key}' is not a parameter of {name}; allowed: "
                f"{', '.join(defaults)}"
            )
        default = defaults[key]
        if isinstance(default, bool):
            fits, what = isinstance(value, bool), "true or false"
        elif isinstance(default, int):
            fits, what = isinstance(value, int) and not isinstance(value, bool), "an integer"
        else:
            fits, what = isinstance(value, int | float) and not isinstance(value, bool), "a number"
        if not fits:
            raise ValueError(f"{source}: key 'imitation.teacher_params.{key}' must be {what}, got {value!r}")
    try:
        planner(**_planner_arguments(params))
    except ValueError as error:
        raise ValueError(f"{source}: key 'imitation.teacher_params': {error}") from error


def make_teacher(name: str, params: Mapping[str, float] | None = None) -> Agent:
    """The teacher agent ``name``: a rule with its shipped gains, or the planner (with ``params`` on its
    defaults) over a batch of envs (a module-level function, so a training job that carries it pickles)."""
    check_teacher_params(name, params or {}, "teacher")
    if name in PLANNERS:
        return PlannerTeacher(params, name)
    return load_agent(name)
