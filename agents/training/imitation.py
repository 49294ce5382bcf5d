"""A teacher start (a lever on the time to a policy): before PPO, the policy learns to act as a teacher
agent does, by DAgger (Ross, Gordon & Bagnell 2011) on the run's own training envs.

Round 0 flies the teacher and records what it saw and did; every later round flies the student (the policy
being trained, deterministic) and records what the teacher would have done in the states the student reaches,
so the student also learns to recover from its own mistakes, which plain behaviour cloning never shows it.
After each round the actor's mean action is fitted to the teacher's actions over everything recorded so far,
and the critic to the discounted returns of the recorded flights, so that PPO's first updates start from a
value estimate rather than from noise.

The teacher is any object with stable-baselines3's ``predict(observation, state, episode_start,
deterministic)`` over a batch; it is passed in (the rules live above this layer, in :mod:`agents.policies`).
The teacher reads the same observation dict as the student, so the run's env must observe every key the
teacher reads; a privileged teacher (the planner) reads, besides, the keys that only envs wrapped in
:class:`~agents.training.student_view.StudentView` show it, never the student.

A student with memory (``frame_stack: k``) acts on, and is fitted to, the stacks of its last k observations
that its envs give; the teacher still labels each state from the current frame alone
(:func:`~agents.training.student_view.teacher_view`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, TypedDict

import numpy as np
import torch
from stable_baselines3.common.vec_env import VecEnv

from agents.common.agent import Agent
from agents.training.student_view import named_arrays, privileged_settings, teacher_view
from agents.training.train_config import ImitationParams

if TYPE_CHECKING:
    from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm


# What a teacher start needs of its teacher: any agent's ``predict``, over a batch of envs.
Teacher = Agent
# Builds the teacher a config names from its name and ``imitation.teacher_params``
# (agents.policies.teachers.make_teacher; the rules live above this layer).
TeacherFactory = Callable[[str, Mapping[str, float]], Teacher]


@dataclass
class Flights:
    """What the envs observed, the teacher's action in each state, and the discounted return from each
    state on (0 beyond the last recorded step of an unfinished episode)."""

    observations: dict[str, np.ndarray]
    teacher_actions: np.ndarray
    returns: np.ndarray

    def __len__(self) -> int:
        return len(self.teacher_actions)

    def joined(self, other: Flights) -> Flights:
        return Flights(
            {
                key: np.concatenate([value, other.observations[key]])
                for key, value in self.observations.items()
            },
            np.concatenate([self.teacher_actions, other.teacher_actions]),
            np.concatenate([self.returns, other.returns]),
        )


def discounted_returns(rewards: np.ndarray, dones: np.ndarray, gamma: float) -> np.ndarray:
    """Per env column of (steps, envs) rewards, the discounted sum of the rewards from each step to the end of
    its episode (``dones[t]`` marks the last step of one); an episode cut by the end of the record counts
    nothing beyond it."""
    if not 0.0 <= gamma <= 1.0:
        raise ValueError(f"gamma must be in [0, 1], got {gamma}")
    returns = np.zeros_like(rewards, dtype=np.float64)
    following = np.zeros(rewards.shape[1])
    for step in range(len(rewards) - 1, -1, -1):
        following = rewards[step] + gamma * following * (1.0 - dones[step])
        returns[step] = following
    return returns


def fly(
    envs: VecEnv, teacher: Teacher, steps: int, gamma: float, student: OnPolicyAlgorithm | None = None
) -> Flights:
    """``steps`` steps of every env in ``envs`` (an SB3 VecEnv), acting as ``student`` does (deterministic) or,
    without one, as the teacher does; the teacher labels every state either way."""
    observation = named_arrays(envs.reset())
    starting = np.ones(envs.num_envs, bool)
    teacher_state = None
    seen: dict[str, list[np.ndarray]] = {key: [] for key in observation}
    labels, rewards, dones = [], [], []
    for _ in range(steps):
        labelled, teacher_state = teacher.predict(
            teacher_view(envs, observation), state=teacher_state, episode_start=starting, deterministic=True
        )
        acted = labelled if student is None else student.predict(observation, deterministic=True)[0]
        for key, value in observation.items():
            seen[key].append(np.array(value))
        labels.append(np.clip(np.asarray(labelled, np.float32), -1.0, 1.0))
        stepped, reward, done, _ = envs.step(np.asarray(acted, np.float32))
        observation = named_arrays(stepped)
        rewards.append(reward)
        dones.append(done)
        starting = np.asarray(done, bool)
    returns = discounted_returns(np.asarray(rewards, np.float64), np.asarray(dones, np.float64), gamma)
    flat = {key: np.concatenate(values) for key, values in seen.items()}
    return Flights(flat, np.concatenate(labels), returns.reshape(-1).astype(np.float32))


def fit(
    model: OnPolicyAlgorithm, flights: Flights, params: ImitationParams, rng: np.random.Generator
) -> dict[str, float]:
    """Fit ``model``'s policy (an SB3 actor-critic) to ``flights``: its mean action to the teacher's (mean
    squared error), its value to the returns (scaled by their spread so neither loss swamps the other).
    Returns the last epoch's mean losses."""
    policy = model.policy
    optimizer = torch.optim.Adam(policy.parameters(), lr=params.learning_rate)
    scale = float(np.std(flights.returns)) or 1.0
    losses = {"action_mse": 0.0, "value_mse_scaled": 0.0}
    policy.set_training_mode(True)
    for _ in range(params.epochs):
        order = rng.permutation(len(flights))
        sums = np.zeros(2)
        for start in range(0, len(order), params.batch_size):
            batch = order[start : start + params.batch_size]
            observation, _ = policy.obs_to_tensor({k: v[batch] for k, v in flights.observations.items()})
            distribution = policy.get_distribution(observation)
            target = torch.as_tensor(flights.teacher_actions[batch])
            action_loss = torch.mean((distribution.mode() - target) ** 2)  # a Gaussian's mode: its mean
            values = policy.predict_values(observation).flatten()
            value_loss = torch.mean(((values - torch.as_tensor(flights.returns[batch])) / scale) ** 2)
            optimizer.zero_grad()
            (action_loss + params.value_weight * value_loss).backward()
            optimizer.step()
            sums += [action_loss.item() * len(batch), value_loss.item() * len(batch)]
        losses = dict(zip(losses, (sums / len(order)).tolist(), strict=True))
    policy.set_training_mode(False)
    return losses


class ImitationSummary(TypedDict):
    """A teacher start, for the run's record: the teacher and the env settings only it read, the env steps and
    wall minutes it took, and per round the states recorded and the fit's losses."""

    teacher: str
    teacher_env: dict[str, object]
    env_steps: int
    wall_minutes: float
    rounds: list[dict[str, float]]


def imitate(
    model: OnPolicyAlgorithm,
    envs: VecEnv,
    teacher: Teacher,
    params: ImitationParams,
    gamma: float,
    seed: int,
) -> ImitationSummary:
    """DAgger: ``params.rounds`` rounds of ``params.steps_per_round`` steps per env on ``envs``, fitting
    ``model``'s policy after each (:func:`fly`, :func:`fit`). Returns a summary for the run's record: the
    env steps used, the wall minutes, and per round the student's agreement with the teacher before its fit."""
    rng = np.random.default_rng(seed)
    started = time.perf_counter()
    recorded: Flights | None = None
    rounds: list[dict[str, float]] = []
    for round_index in range(params.rounds):
        student = None if round_index == 0 else model
        flights = fly(envs, teacher, params.steps_per_round, gamma, student=student)
        recorded = flights if recorded is None else recorded.joined(flights)
        losses = fit(model, recorded, params, rng)
        rounds.append(
            {"round": round_index, "states": len(recorded), **{k: round(v, 5) for k, v in losses.items()}}
        )
        print(
            f"imitation round {round_index + 1}/{params.rounds}: {len(recorded):,} states, "
            f"action mse {losses['action_mse']:.4f}"
        )
    steps = params.rounds * params.steps_per_round * envs.num_envs
    return {
        "teacher": params.teacher,
        # The teacher's own env opt-in (the planner's observe_layout), which the student never saw.
        "teacher_env": privileged_settings(teacher),
        "env_steps": steps,
        "wall_minutes": round((time.perf_counter() - started) / 60.0, 2),
        "rounds": rounds,
    }
