"""What running an outside agent apart from the scorer costs per env step (``flownav bench isolation``).

The same agent flies the same env in blocks of steps, in turn loaded here (as before isolation), in a plain
process of its own (``--no-sandbox``) and in its sandbox (:class:`~agents.policies.agent_process.IsolatedAgent`,
as ``flownav score`` flies it), the order rotating between repeats; each repeat's cost is the ratio of a block's
time per step to the in-process block's, quoted as a median over repeats, so that a machine shared with other jobs
shifts every side alike. The target: under 10 % of a step.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from agents.common.locations import REPO_ROOT
from agents.common.tables import markdown_table, write_csv
from agents.evaluation.provenance import machine_summary
from agents.policies import Agent
from agents.policies.agent_limits import AgentLimits
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


# The sides measured, in the order of the first repeat: in process, in a plain process, in the sandbox.
SIDES = ("in_process", "own_process", "sandbox")


def measure_isolation_cost(
    agent: str = DEFAULT_AGENT, *, tier_name: str = "clean", steps: int = 100, repeats: int = 5, seed: int = 0
) -> list[dict[str, float]]:
    """Per repeat: ms per step with ``agent`` loaded here, in a plain process of its own and in its sandbox, and
    each one's ratio to in process; and ms per ``predict`` alone on each side; the sides rotate which goes first.

    Raises:
        ValueError: fewer than 1 step or repeat, or an agent that does not load.
    """
    if steps < 1 or repeats < 1:
        raise ValueError(f"steps and repeats must be >= 1, got {steps} and {repeats}")
    spec = canonical_spec(agent)
    spec_tier = tier(tier_name)
    env = gym.make(spec_tier.env_id, **spec_tier.settings)
    apart, sandboxed = IsolatedAgent(spec, limits=AgentLimits(sandboxed=False)), IsolatedAgent(spec)
    fliers: dict[str, Agent] = {
        "in_process": load_external_agent(spec),
        "own_process": apart,
        "sandbox": sandboxed,
    }
    rows = []
    try:
        for flier in fliers.values():  # each warmed up: the processes started, the first frames rendered
            time_per_step(env, flier, 5, seed)
        observation, _ = env.reset(seed=seed)
        for repeat in range(repeats):
            order = [*SIDES[repeat % len(SIDES) :], *SIDES[: repeat % len(SIDES)]]
            timings = {name: time_per_step(env, fliers[name], steps, seed + repeat) for name in order}
            predicts = {name: time_per_predict(fliers[name], observation, steps) for name in order}
            row: dict[str, Any] = {"repeat": repeat}
            row.update({f"{name}_ms": 1e3 * timings[name] for name in SIDES})
            row.update({f"{name}_ratio": timings[name] / timings["in_process"] for name in SIDES[1:]})
            row.update({f"predict_{name}_ms": 1e3 * predicts[name] for name in SIDES})
            rows.append(row)
    finally:
        apart.close()
        sandboxed.close()
        env.close()
    return rows


def _side_sentence(rows: Sequence[Mapping[str, float]], name: str, words: str) -> str:
    """What flying the agent on side ``name`` (in ``words``) costs, in a sentence of medians over ``rows``."""
    step = statistics.median(row["in_process_ms"] for row in rows)
    ratio = statistics.median(row[f"{name}_ratio"] for row in rows)
    verdict = "within" if ratio - 1.0 <= TARGET_OVERHEAD else "over"
    added = statistics.median(row[f"predict_{name}_ms"] - row["predict_in_process_ms"] for row in rows)
    return (
        f"In {words}: median ratio of time per step to in process {ratio:.3f} ({100 * (ratio - 1):+.1f} %), "
        f"{verdict} the target of {100 * TARGET_OVERHEAD:.0f} %; a `predict` alone, with no step around it, "
        f"takes {added:.3f} ms more ({100 * added / step:.1f} % of the median step in process, {step:.2f} ms), "
        "a figure less shaken by other jobs on the machine than the ratio of whole steps."
    )


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
    sentences = [
        _side_sentence(rows, name, words)
        for name, words in (("own_process", "a plain process of its own"), ("sandbox", "its sandbox"))
    ]
    headers = ["repeat", *(f"{name.replace('_', ' ')} (ms/step)" for name in SIDES)]
    headers += [f"{name.replace('_', ' ')} ratio" for name in SIDES[1:]]
    headers += [f"predict {name.replace('_', ' ')} (ms)" for name in SIDES]
    lines = [
        "# The cost of flying an outside agent apart from the scorer",
        "",
        f"Generated by `flownav bench isolation --steps {steps} --repeats {len(rows)}` on {machine_summary()}.",
        "",
        f"{len(rows)} repeats of {steps} steps of `{Path(agent.rpartition(':')[0]).name}` on the clean tier, the "
        f"order of the three sides rotating between repeats. {' '.join(sentences)}",
        "",
        markdown_table(
            headers,
            [
                [
                    row["repeat"],
                    *(f"{row[f'{name}_ms']:.2f}" for name in SIDES),
                    *(f"{row[f'{name}_ratio']:.3f}" for name in SIDES[1:]),
                    *(f"{row[f'predict_{name}_ms']:.3f}" for name in SIDES),
                ]
                for row in rows
            ],
        ),
    ]
    md_path.write_text("\n".join(lines) + "\n")
    return [csv_path, md_path]
