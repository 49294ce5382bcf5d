"""What running an outside agent in a process of its own costs per env step (``flownav bench isolation``).

The same agent flies the same env in blocks of steps, alternately loaded here (as before isolation) and in its
own process (:class:`~agents.policies.agent_process.IsolatedAgent`, as ``flownav score`` flies it); each repeat's
cost is the ratio of the two blocks' time per step, quoted as a median over repeats, so that a machine shared with
other jobs shifts both sides alike. The target: under 10 % of a step.
"""

from __future__ import annotations

import statistics
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from agents.common.locations import REPO_ROOT
from agents.common.tables import markdown_table, write_csv
from agents.policies import Agent
from agents.policies.agent_process import IsolatedAgent
from agents.policies.external import canonical_spec, load_external_agent
from flownav_env.tiers import tier

# The example agent of tests/examples, a rule as cheap as an agent gets: the cost measured is the separation's.
DEFAULT_AGENT = f"{REPO_ROOT / 'tests' / 'examples' / 'open_gap_agent.py'}:make_agent"
# The separation may cost at most this share of a step.
TARGET_OVERHEAD = 0.10


def time_per_step(env: gym.Env, agent: Agent, steps: int, seed: int) -> float:
    """Seconds per env step (``predict`` and ``step``) of ``agent`` flying ``env`` for ``steps`` steps from
    ``reset(seed)``, a new episode whenever one ends."""
    observation, _ = env.reset(seed=seed)
    start = True
    began = time.perf_counter()
    for _ in range(steps):
        action, _ = agent.predict(observation, None, np.array([start]), True)
        observation, _, terminated, truncated, _ = env.step(action)
        start = terminated or truncated
        if start:
            observation, _ = env.reset()
    return (time.perf_counter() - began) / steps


def time_per_predict(agent: Agent, observation: dict[str, np.ndarray], calls: int) -> float:
    """Seconds per ``predict`` of ``agent`` on ``observation``, ``calls`` times: what the separation adds to a
    step, without the step's own time and its noise."""
    began = time.perf_counter()
    for call in range(calls):
        agent.predict(observation, None, np.array([call == 0]), True)
    return (time.perf_counter() - began) / calls


def measure_isolation_cost(
    agent: str = DEFAULT_AGENT, *, tier_name: str = "clean", steps: int = 100, repeats: int = 5, seed: int = 0
) -> list[dict[str, Any]]:
    """Per repeat: ms per step with ``agent`` loaded here and in its own process, and their ratio; and ms per
    ``predict`` alone on each side; the two sides alternate which goes first.

    Raises:
        ValueError: fewer than 1 step or repeat, or an agent that does not load.
    """
    if steps < 1 or repeats < 1:
        raise ValueError(f"steps and repeats must be >= 1, got {steps} and {repeats}")
    spec = canonical_spec(agent)
    spec_tier = tier(tier_name)
    env = gym.make(spec_tier.env_id, **spec_tier.settings)
    here, apart = load_external_agent(spec), IsolatedAgent(spec)
    rows = []
    try:
        time_per_step(env, apart, 5, seed)  # both warmed up: the process started, the first frames rendered
        time_per_step(env, here, 5, seed)
        observation, _ = env.reset(seed=seed)
        for repeat in range(repeats):
            order = [("in_process", here), ("own_process", apart)]
            if repeat % 2:
                order.reverse()
            timings = {name: time_per_step(env, flier, steps, seed + repeat) for name, flier in order}
            predicts = {name: time_per_predict(flier, observation, steps) for name, flier in order}
            rows.append(
                {
                    "repeat": repeat,
                    "in_process_ms": 1e3 * timings["in_process"],
                    "own_process_ms": 1e3 * timings["own_process"],
                    "ratio": timings["own_process"] / timings["in_process"],
                    "predict_in_process_ms": 1e3 * predicts["in_process"],
                    "predict_own_process_ms": 1e3 * predicts["own_process"],
                }
            )
    finally:
        apart.close()
        env.close()
    return rows


def run_isolation_benchmark(
    agent: str = DEFAULT_AGENT, *, steps: int = 100, repeats: int = 5, out_dir: Path = Path("runs/bench")
) -> list[Path]:
    """Measure (:func:`measure_isolation_cost`) and write ``isolation_cost.csv`` and ``isolation_cost.md`` into
    ``out_dir``; returns their paths."""
    rows = measure_isolation_cost(agent, steps=steps, repeats=repeats)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    csv_path, md_path = out_dir / "isolation_cost.csv", out_dir / "isolation_cost.md"
    write_csv(
        csv_path, [{k: round(v, 4) if isinstance(v, float) else v for k, v in row.items()} for row in rows]
    )
    ratio = statistics.median(row["ratio"] for row in rows)
    verdict = "within" if ratio - 1.0 <= TARGET_OVERHEAD else "over"
    added = statistics.median(row["predict_own_process_ms"] - row["predict_in_process_ms"] for row in rows)
    step = statistics.median(row["in_process_ms"] for row in rows)
    lines = [
        "# The cost of flying an outside agent in its own process",
        "",
        f"{len(rows)} alternated repeats of {steps} steps of `{agent}` on the clean tier. Median ratio of time per "
        f"step, own process / in process: {ratio:.3f} ({100 * (ratio - 1):+.1f} %), {verdict} the target of "
        f"{100 * TARGET_OVERHEAD:.0f} %. A `predict` alone, with no step around it, takes {added:.3f} ms more in "
        f"its own process (median over repeats): {100 * added / step:.1f} % of the median step in process "
        f"({step:.2f} ms), a figure less shaken by other jobs on the machine than the ratio of whole steps.",
        "",
        markdown_table(
            [
                "repeat",
                "in process (ms/step)",
                "own process (ms/step)",
                "ratio",
                "predict in process (ms)",
                "predict own process (ms)",
            ],
            [
                [
                    row["repeat"],
                    f"{row['in_process_ms']:.2f}",
                    f"{row['own_process_ms']:.2f}",
                    f"{row['ratio']:.3f}",
                    f"{row['predict_in_process_ms']:.3f}",
                    f"{row['predict_own_process_ms']:.3f}",
                ]
                for row in rows
            ],
        ),
    ]
    md_path.write_text("\n".join(lines) + "\n")
    return [csv_path, md_path]
