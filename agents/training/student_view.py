"""A teacher start whose teacher reads what no sensor gives (the privileged planner): the training envs observe
the privileged keys (``observe_layout=True``, :mod:`flownav_env.privileged`) for the teacher alone, and the
student, whose policy and observation space are built on :class:`StudentView`, never sees them.

The opt-in belongs to the teacher, not to the run's ``env`` section: the policy shipped from the run is an ordinary
agent, evaluated with that section alone, so it must ask a tier for nothing privileged.

A student with memory (``frame_stack``) sees a ``VecFrameStack`` over the view; the teacher still reads the
current frame alone, the view's :attr:`StudentView.full_observation` (:func:`teacher_view` finds it beneath
the stack).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper, VecFrameStack
from stable_baselines3.common.vec_env.base_vec_env import VecEnvObs, VecEnvStepReturn

from flownav_env.privileged import PRIVILEGED_KEYS


def named_arrays(observation: VecEnvObs) -> dict[str, np.ndarray]:
    """``observation`` of a vector env, checked to be what every FlowNav env observes: named arrays (a dict).

    Raises:
        ValueError: another kind of observation (one array, a tuple).
    """
    if not isinstance(observation, dict):
        raise ValueError(f"a FlowNav env observes named arrays (a dict), got {type(observation).__name__}")
    return observation


class StudentView(VecEnvWrapper):
    """A vector env whose observations (and space) lack :data:`~flownav_env.privileged.PRIVILEGED_KEYS`, while
    the full observation of the latest reset or step stays readable for the teacher (:func:`teacher_view`).

    Wrapping an env that observes no privileged key changes nothing; the evaluation env is wrapped too, so that
    SB3's evaluation sees the same env class as training.
    """

    def __init__(self, venv: VecEnv) -> None:
        full = venv.observation_space
        if not isinstance(full, spaces.Dict):
            raise ValueError(f"StudentView needs a dict observation space, got {type(full).__name__}")
        student = spaces.Dict({k: v for k, v in full.spaces.items() if k not in PRIVILEGED_KEYS})
        super().__init__(venv, observation_space=student)
        self.full_observation: dict[str, np.ndarray] = {}

    def _student(self, observation: VecEnvObs) -> dict[str, np.ndarray]:
        self.full_observation = named_arrays(observation)
        return {k: v for k, v in self.full_observation.items() if k not in PRIVILEGED_KEYS}

    def reset(self) -> dict[str, np.ndarray]:
        return self._student(self.venv.reset())

    def step_wait(self) -> VecEnvStepReturn:
        observation, rewards, dones, infos = self.venv.step_wait()
        # The terminal observation SB3 keeps for bootstrapping is the student's too.
        for info in infos:
            if "terminal_observation" in info:
                info["terminal_observation"] = {
                    k: v for k, v in info["terminal_observation"].items() if k not in PRIVILEGED_KEYS
                }
        return self._student(observation), rewards, dones, infos


def teacher_view(envs: VecEnv, observation: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """What the teacher reads in the state whose student observation is ``observation``: the current frame's
    full observation when ``envs`` is, or wraps, a :class:`StudentView` that holds one, else ``observation``
    itself.

    Raises:
        ValueError: ``envs`` stack frames (``VecFrameStack``) over no :class:`StudentView`: ``observation``
            is then a stack, and a teacher reads one frame.
    """
    stack: VecFrameStack | None = None
    inner: VecEnv = envs
    while isinstance(inner, VecEnvWrapper):
        if isinstance(inner, StudentView):
            return inner.full_observation or observation
        if isinstance(inner, VecFrameStack):
            stack = inner
        inner = inner.venv
    if stack is not None:
        raise ValueError(
            f"a teacher reads one frame, but these envs stack {stack.stacked_obs.n_stack} frames over no "
            "StudentView to read the current frame from: wrap the envs in StudentView beneath VecFrameStack"
        )
    return observation


def privileged_settings(teacher: object) -> dict[str, object]:
    """The env settings a teacher reads that its student must not see (``{"observe_layout": True}`` for the
    planner), as the teacher declares them in ``privileged_settings``; empty for a teacher that reads only the
    student's observation.

    Raises:
        ValueError: a declared setting other than ``observe_layout``: only its keys can be hidden from the
            student (true depths replace the student's own histogram).
    """
    settings: Mapping[str, object] = getattr(teacher, "privileged_settings", {}) or {}
    other = sorted(set(settings) - {"observe_layout"})
    if other:
        raise ValueError(
            f"a teacher's privileged settings may only be observe_layout (its keys are hidden from the student), "
            f"got {', '.join(other)}"
        )
    return dict(settings)
