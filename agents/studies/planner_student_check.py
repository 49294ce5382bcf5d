"""The planner's flow-only student (``configs/experiments/ppo_flow_planner_student.yaml``) against ``bee_ttc`` on
validation layouts (:data:`agents.common.seeds.STUDENT_CHECK_SEED_START`), per tier: failure = no success.

``python -m agents.studies.planner_student_check --agent bee_ttc`` or ``--policy runs/.../<name>.zip``; appends one
JSON line per (agent, tier) to ``--out``. Every agent flies the tier's settings plus only the observation keys it
asks for (checked by :func:`flownav_env.tiers.check_agent_settings`).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import gymnasium as gym

import flownav_env  # noqa: F401  (registers the tier ids)
from agents.common.seeds import STUDENT_CHECK_SEED_START
from agents.common.yaml_config import load_config
from agents.evaluation.episode import run_episode
from agents.policies.base import Agent
from agents.policies.learned import agent_env_kwargs, load_agent
from agents.policies.loading import load_policy_file
from agents.training.train_config import TrainConfig
from flownav_env.tiers import TIER_NAMES, check_agent_settings, tier


def fly_tier(label: str, agent: Agent, env_kwargs: dict, tier_name: str, layouts: int) -> dict:
    """``layouts`` episodes of ``agent`` on ``tier_name`` from the student-check seeds; its failure rate."""
    check_agent_settings(label, env_kwargs, tier_name)
    env = gym.make(tier(tier_name).env_id, **env_kwargs)
    started = time.perf_counter()
    try:
        records = [
            run_episode(env, agent, seed, label=label)
            for seed in range(STUDENT_CHECK_SEED_START, STUDENT_CHECK_SEED_START + layouts)
        ]
    finally:
        env.close()
    failures = sum(not r.success for r in records)
    return {
        "agent": label,
        "tier": tier_name,
        "layouts": layouts,
        "failures": failures,
        "failure_rate": round(failures / layouts, 3),
        "collisions": sum(r.collision for r in records),
        "minutes": round((time.perf_counter() - started) / 60.0, 2),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--agent", help="a named agent, e.g. bee_ttc")
    parser.add_argument("--policy", help="a trained policy .zip with its config beside it")
    parser.add_argument("--layouts", type=int, default=50)
    parser.add_argument("--tiers", default=",".join(TIER_NAMES))
    parser.add_argument("--out", default="planner_student_check.jsonl")
    args = parser.parse_args()
    if args.policy:
        # runs/<dir>/<name>/seed_<k>/seed_<k>.zip -> <name>/seed_<k>: the run as well as its seed
        label = f"{Path(args.policy).parent.parent.name}/{Path(args.policy).stem}"
        agent = load_policy_file(Path(args.policy))
        env_kwargs = dict(_policy_env(Path(args.policy)))
    else:
        label, agent, env_kwargs = args.agent, load_agent(args.agent), agent_env_kwargs(args.agent)
    for tier_name in args.tiers.split(","):
        row = fly_tier(label, agent, env_kwargs, tier_name, args.layouts)
        print(json.dumps(row), flush=True)
        with open(args.out, "a") as out:
            out.write(json.dumps(row) + "\n")


def _policy_env(policy: Path) -> dict:

    return load_config(policy.with_suffix(".yaml"), TrainConfig).env


if __name__ == "__main__":
    main()
