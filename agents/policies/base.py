"""What every agent is: something with stable-baselines3's ``predict`` (:class:`Agent`, declared in the bottom
layer for training's teachers too), the base of agents that wrap another, and the names the benchmark knows."""

from __future__ import annotations

from typing import Any

import numpy as np

from agents.common.agent import Agent  # the agents' one interface, named from here above the bottom layer

REACTIVE_AGENTS = ("straight", "bee", "bee_robust", "bee_ttc", "vfh")
# ppo_flow_course_approach_curriculum_slow: the lever search's winner, trained from configs/experiments/ (its name lists
# its levers: course distribution, approach input, a gentler second curriculum stage; results/flow_gap.md).
# ppo_flow_course_approach_curriculum_slow_oracle: the same recipe told the true depths at the same tracked points,
# the yardstick of what flow costs it (the true-depth comparison), as ppo_oracle is ppo_flow's.
# ppo_flow_planner_student: the privileged planner distilled (DAgger) into a flow-only policy, one policy trained
# across the tiers' courses and sensors (configs/experiments/ppo_flow_planner_student.yaml); its _oracle twin is
# the same recipe on the true depths at the same tracked points, what flow costs the student.
LEARNED_AGENTS = (
    "ppo_flow",
    "ppo_robust",
    "ppo_oracle",
    "ppo_flow_course_approach_curriculum_slow",
    "ppo_flow_course_approach_curriculum_slow_oracle",
    "ppo_flow_planner_student",
    "ppo_flow_planner_student_oracle",
)
# Learned agents trained across the tiers, flown on the suite only: the clean tier's history table predates them.
SUITE_ONLY_AGENTS = ("ppo_flow_planner_student", "ppo_flow_planner_student_oracle")
# Agents that plan with the whole course known (agents/policies/planner.py): what a tier allows at all; and the
# same planning knowing only the capsules the camera has seen (agents/policies/planner_camera.py): at their
# exact positions (what the camera's view allows), or as the observation's histogram resolves them (what the
# observation's resolution allows).
PLANNERS = ("planner", "planner_camera", "planner_camera_observed")
AGENT_NAMES = REACTIVE_AGENTS + LEARNED_AGENTS + PLANNERS
# The agents of the clean tier's history table: every agent but the planners, which are flown only on the suite,
# as each tier's bound, and the suite-only learned agents. (The demo flies every rule and every shipped policy.)
HISTORY_AGENTS = REACTIVE_AGENTS + tuple(agent for agent in LEARNED_AGENTS if agent not in SUITE_ONLY_AGENTS)
# The agents that read what a tier's sensor does not give (true depths at the tracked points; the capsule layout
# and the true state). Each is a reference of what perfect sensing allows: listed apart in every table, never
# ranked or named best. An agent whose settings ask for privileged data without being listed here is refused by
# the suite.
PRIVILEGED_AGENTS = (
    "ppo_oracle",
    "ppo_flow_course_approach_curriculum_slow_oracle",
    "ppo_flow_planner_student_oracle",
    "planner",
    "planner_camera",
    "planner_camera_observed",
)
# Agents retired from the suite: neither flown nor ranked there any more, each with why. They keep their names, so
# the committed sweep, robustness profiles and the clean tier's history table still read their episodes, and the
# suite's report lists each one's flown seeds per tier from the episodes it kept.
RETIRED_AGENTS = {
    "ppo_robust": (
        "trained on clean courses across the sweep's error models, never on a tier's course or sensor, with too "
        "few training seeds to rank and seeds far apart"
    ),
}
# The agents the suite flies and ranks (with its references): every agent but the retired ones.
SUITE_AGENTS = tuple(agent for agent in AGENT_NAMES if agent not in RETIRED_AGENTS)
# A learned agent's training seed k is named "<agent>@<k>" (ppo_flow@3): its policy is
# results/policies/<agent>/seed_<k>.zip, and episode records keep the seeds apart by name.
TRAIN_SEED_MARK = "@"


def check_not_retired(name: str) -> str:
    """``name`` itself, unless it names an agent retired from the suite (or one of its training seeds).

    Raises:
        ValueError: a retired agent, with why it was retired.
    """
    base = base_agent_name(name)
    if base in RETIRED_AGENTS:
        raise ValueError(
            f"{name!r} is retired from the suite ({RETIRED_AGENTS[base]}); fly it with flownav evaluate, or "
            "name an agent of the suite"
        )
    return name


def split_agent_name(name: str) -> tuple[str, int | None]:
    """``"ppo_flow@3"`` → ``("ppo_flow", 3)``; ``"bee"`` → ``("bee", None)``; an outside agent
    (``my_module:make_agent``) → itself and None.

    Raises:
        ValueError: an unknown agent, a training seed on a reactive agent, or a seed that is not an integer >= 0.
    """
    if ":" in str(name):  # written outside FlowNav (agents.policies.external)
        return str(name), None
    base, mark, seed_text = str(name).partition(TRAIN_SEED_MARK)
    allowed = (
        f"one of {', '.join(AGENT_NAMES)}, <learned agent>@<training seed> such as ppo_flow@0, or an agent "
        "of your own as module.path:callable or path/to/file.py:callable"
    )
    if base not in AGENT_NAMES:
        raise ValueError(f"agent must be {allowed}, got {name!r}")
    if not mark:
        return base, None
    if base not in LEARNED_AGENTS:
        raise ValueError(
            f"only learned agents have training seeds ({', '.join(LEARNED_AGENTS)}), got {name!r}"
        )
    if not seed_text.isdigit():
        raise ValueError(f"a training seed must be an integer >= 0, got {name!r}")
    return base, int(seed_text)


def base_agent_name(name: str) -> str:
    """The agent a run name belongs to, whatever follows the seed mark: ``ppo_flow@3`` and the sweep's pooled
    ``ppo_flow@all`` → ``ppo_flow``; ``bee`` → ``bee``. Not validated (see :func:`split_agent_name`)."""
    return str(name).partition(TRAIN_SEED_MARK)[0]


def seeded_agent_name(agent: str, train_seed: int) -> str:
    """The name of training seed ``train_seed`` of the learned ``agent``: ``ppo_flow@3``."""
    return f"{agent}{TRAIN_SEED_MARK}{train_seed}"


def is_learned(name: str) -> bool:
    """Whether ``name`` (with or without a training seed) is a learned agent."""
    return split_agent_name(name)[0] in LEARNED_AGENTS


class AgentWrapper:
    """An agent that flies another one, ``agent``: ``predict`` passes each call through, on what
    :meth:`observe` makes of the observation. A wrapper overrides :meth:`observe` to check or convert the
    observation, and ``predict`` itself (calling this one) to change the call around it.
    """

    def __init__(self, agent: Agent) -> None:
        self.agent = agent

    def predict(
        self,
        observation: dict[str, np.ndarray],
        state: Any = None,
        episode_start: np.ndarray | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]:
        """``agent``'s ``predict`` on :meth:`observe`'s view of ``observation``."""
        return self.agent.predict(
            self.observe(observation), state=state, episode_start=episode_start, deterministic=deterministic
        )

    def observe(self, observation: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """What ``agent`` is given of ``observation``: the observation itself, unless a wrapper checks or
        converts it here (raising a ValueError for one it refuses)."""
        return observation
