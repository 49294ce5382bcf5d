"""The values of the benchmark's clean-course sections: the leading table, what the reactive rules leave to
learning, the flow-gap levers on validation layouts and the flow-gap targets on test layouts, and the set-up. Each figure
is computed from :class:`~agents.studies.benchmark_data.BenchmarkData`; each verdict is a ``bool`` that picks a
wording in the template, or a phrase built by :mod:`agents.studies.benchmark_claims`."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

from agents.common.seeds import ABLATION_SEED_START, TEST_SEED_START, VALIDATION_SEED_START
from agents.common.tables import markdown_table
from agents.policies.base import LEARNED_AGENTS, PRIVILEGED_AGENTS, REACTIVE_AGENTS
from agents.studies.benchmark_claims import (
    WINNER,
    WINNER_ON_TRUE_DEPTHS,
    delta,
    interval,
    join_words,
    paired_reading,
    rate,
)
from agents.studies.benchmark_data import BenchmarkData, Rate, commit_of
from agents.studies.error_analysis import is_flow_agent
from flownav_env.settings import EnvSettings

# The flow-gap targets: the best flow-only agent fails at most this much on clean test layouts and no worse than
# this multiple of the oracle's rate, stays within this much of its clean rate at the speed and density below,
# and trains in at most this many minutes per seed.
TARGET_MAX_FAILURE = 0.12
TARGET_ORACLE_FACTOR = 2.0
ROBUSTNESS_MAX_RISE = 0.10
ROBUSTNESS_SPEED = 1.5
ROBUSTNESS_DENSITY = 0.18
TRAINING_BUDGET_MINUTES = 60.0

# What each agent is, for the tables.
DESCRIPTIONS = {
    "straight": "no avoidance",
    "bee": "bee-style centring",
    "bee_robust": "centring on robust sector statistics",
    "bee_ttc": "`bee_robust` on the rate of approach",
    "vfh": "vector field histogram",
    "ppo_flow": "PPO on flow depths",
    "ppo_robust": "PPO on flow, sensor errors in training",
    "ppo_oracle": "PPO on true depths, same points",
    WINNER: "PPO on flow and the rate of approach, over speeds and densities; the lever search's winner",
    WINNER_ON_TRUE_DEPTHS: "the winner's recipe on true depths, same points",
}
VSEP = "–"


Values = dict[str, str | bool]


def count(value: float) -> str:
    """A count with thousands separators: ``43,400``."""
    return f"{value:,.0f}"


def span(values: Sequence[float], digits: int = 0) -> str:
    """``36–59``: the smallest and largest value, or one where they print alike."""
    low, high = f"{min(values):,.{digits}f}", f"{max(values):,.{digits}f}"
    return low if low == high else f"{low}{VSEP}{high}"


def seed_list(seeds: Sequence[int]) -> str:
    """``0-4`` for consecutive seeds, else ``0,2,3``."""
    ordered = sorted(seeds)
    if ordered == list(range(ordered[0], ordered[-1] + 1)) and len(ordered) > 1:
        return f"{ordered[0]}-{ordered[-1]}"
    return ",".join(map(str, ordered))


def learning_rate(value: float) -> str:
    """``1e-4``."""
    mantissa, exponent = f"{value:.0e}".split("e")
    return f"{mantissa}e{int(exponent)}"


def _fail(row: dict[str, Any]) -> str:
    return interval(row["failure_rate"], row["failure_low"], row["failure_high"])


def best_agents(data: BenchmarkData) -> tuple[dict[str, Any], dict[str, Any]]:
    """The reactive agent (straight aside) and the learned flow agent with the lowest clean failure rate; a
    privileged agent (it reads what the sensor does not give) is a reference, never among them."""
    reactive = [r for r in data.leaderboard if r["agent"] in REACTIVE_AGENTS and r["agent"] != "straight"]
    learned = [
        r
        for r in data.leaderboard
        if r["agent"] in LEARNED_AGENTS and is_flow_agent(r) and r["agent"] not in PRIVILEGED_AGENTS
    ]
    return min(reactive, key=lambda r: r["failure_rate"]), min(learned, key=lambda r: r["failure_rate"])


def leaderboard_values(data: BenchmarkData) -> Values:
    """The leading table, its provenance, the training seeds' spread and the probabilities of improvement."""
    complete = all(r["episodes"] == r["runs"] * len(data.layouts) for r in data.leaderboard)
    return {
        "leaderboard_episodes": count(data.leaderboard_episodes),
        "leaderboard_layouts": f"{data.layouts[0]:,}{VSEP}{data.layouts[-1]:,}",
        "leaderboard_complete": complete,
        "leaderboard_code": _code_versions(data),
        "layouts_per_run": str(len(data.layouts)),
        "leaderboard_table": _leaderboard_table(data),
        "block": str(data.block),
        "seed_ranges": _seed_ranges(data),
        "improvement_table": _improvement_table(data),
    }


def _leaderboard_table(data: BenchmarkData) -> str:
    """The leading table, the best reactive and the best learned flow agent in bold."""
    best_reactive, best_learned = best_agents(data)
    bold = {best_reactive["agent"], best_learned["agent"]}
    rows = []
    for r in data.leaderboard:
        name, failure = f"`{r['agent']}`", _fail(r)
        if r["agent"] in bold:
            name, failure = f"**{name}**", f"**{failure}**"
        iqm = (
            "–" if r["runs"] == 1 else interval(r["iqm_failure"], r["iqm_failure_low"], r["iqm_failure_high"])
        )
        rows.append(
            [
                f"{name} ({DESCRIPTIONS.get(r['agent'], r['agent'])})",
                r["runs"],
                failure,
                interval(r["success_rate"], r["success_low"], r["success_high"]),
                rate(r["collision_rate"]),
                rate(r["out_of_bounds_rate"]),
                iqm,
            ]
        )
    header = ["agent", "runs", "failure rate [95 % CI]", "success rate [95 % CI]", "collision"]
    header += ["out of bounds", "IQM failure [95 % CI]"]
    return markdown_table(header, rows)


def _code_versions(data: BenchmarkData) -> str:
    """The commits each agent's episodes were flown at, agents with the same commits named together."""
    groups: dict[tuple[str, ...], list[str]] = {}
    for agent, versions in data.code_versions.items():
        groups.setdefault(tuple(commit_of(v) for v in versions), []).append(f"`{agent}`")
    return "; ".join(
        f"{join_words(list(commits))} ({join_words(agents)})" for commits, agents in groups.items()
    )


def _improvement_table(data: BenchmarkData) -> str:
    """The probability that each learned agent fails less than each reactive one (straight aside)."""
    learned = [r["agent"] for r in data.leaderboard if r["agent"] in LEARNED_AGENTS]
    reactive = [
        r["agent"] for r in data.leaderboard if r["agent"] in REACTIVE_AGENTS and r["agent"] != "straight"
    ]
    improvement = [
        [
            f"`{x}`",
            *(interval(*(data.gain(x, y)[k] for k in ("probability", "low", "high"))) for y in reactive),
        ]
        for x in learned
    ]
    return markdown_table(["learned X", *(f"over `{y}`" for y in reactive)], improvement)


def _seed_ranges(data: BenchmarkData) -> str:
    """Each learned agent's failure rates over its seeds, with its worst seed and that seed's out-of-bounds
    share."""
    parts = []
    for agent in (r["agent"] for r in data.leaderboard if r["agent"] in LEARNED_AGENTS):
        seeds = [r for r in data.seed_rows if r["agent"] == agent]
        worst = max(seeds, key=lambda r: r["failure_rate"])
        parts.append(
            f"`{agent}` {span([r['failure_rate'] for r in seeds], 2)} (worst: seed {worst['train_seed']}, "
            f"{rate(worst['failure_rate'])}, of it {rate(worst['out_of_bounds_rate'])} out of bounds)"
        )
    return "; ".join(parts)


def reactive_gap_values(data: BenchmarkData) -> Values:
    """What the strongest reactive rule leaves to learning on clean test layouts: each comparison of two agents
    paired by layout (:meth:`BenchmarkData.compare`)."""
    best_reactive, best_learned = best_agents(data)
    ttc, flow, winner = (data.row(a) for a in ("bee_ttc", "ppo_flow", WINNER))
    best = data.compare(best_learned["agent"], best_reactive["agent"])
    closing = (flow["failure_rate"] - winner["failure_rate"]) / (flow["failure_rate"] - ttc["failure_rate"])
    # The winner's recipe on true depths (its twin: what flow costs it) once it is in the leading table.
    truth = next((r for r in data.leaderboard if r["agent"] == WINNER_ON_TRUE_DEPTHS), None)
    return {
        "truth_recipe": WINNER_ON_TRUE_DEPTHS,
        "truth_recipe_flown": truth is not None,
        "fail_truth_recipe": _fail(truth) if truth else "",
        "winner_vs_truth_recipe": paired_reading(data.compare(WINNER, WINNER_ON_TRUE_DEPTHS))
        if truth
        else "",
        "learned_beats_reactive": best.fails_less == best.agent,
        "reactive_beats_learned": best.fails_less == best.reference,
        "best_learned_vs_reactive": paired_reading(best),
        "best_learned": f"`{best_learned['agent']}`",
        "best_reactive": f"`{best_reactive['agent']}`",
        "fail_bee_ttc": _fail(ttc),
        "fail_bee_robust": _fail(data.row("bee_robust")),
        "fail_ppo_flow": _fail(flow),
        "runs_ppo_flow": str(flow["runs"]),
        "ppo_flow_vs_ttc": paired_reading(data.compare("ppo_flow", "bee_ttc")),
        "fail_ppo_oracle": _fail(data.row("ppo_oracle")),
        "fail_winner": _fail(winner),
        "winner_vs_ttc": paired_reading(data.compare(WINNER, "bee_ttc")),
        "winner_closes": f"closing {100 * closing:.0f} %",
    }


def _within(clean: Rate, *conditions: Rate) -> bool:
    return all(c.rate - clean.rate <= ROBUSTNESS_MAX_RISE for c in conditions)


def validation_values(data: BenchmarkData) -> Values:
    """The flow-gap levers and the reactive references on validation layouts: clean, at density 0.18 and at
    1.5 m/s, each with its difference from clean."""
    table, within = _validation_table(data)
    per_run = {c: {r.episodes // r.runs for r in data.validation[c].values()} for c in data.validation}
    return {
        "validation_table": table,
        "validation_within": join_words([f"`{n}`" for n in within]) or "none",
        "validation_clean_layouts": "/".join(map(str, sorted(per_run["clean"]))),
        "validation_condition_layouts": "/".join(map(str, sorted(per_run["density"] | per_run["speed"]))),
        **_winner_training_values(data),
        "robustness_limit": f"{ROBUSTNESS_MAX_RISE:.2f}",
        "robustness_density": f"{ROBUSTNESS_DENSITY:g}",
        "robustness_speed": f"{ROBUSTNESS_SPEED:g}",
    }


def _validation_table(data: BenchmarkData) -> tuple[str, list[str]]:
    """The validation table (levers first, then the reactive references) and the names within the robustness
    limit at both conditions."""
    clean, density, speed = (data.validation[c] for c in ("clean", "density", "speed"))
    names = [name for name in clean if name in density and name in speed]
    names = [n for n in names if n not in REACTIVE_AGENTS] + [n for n in names if n in REACTIVE_AGENTS]
    rows, within = [], []
    for name in names:
        ok = _within(clean[name], density[name], speed[name])
        within += [name] if ok else []
        label = f"`{name}` (reactive)" if name in REACTIVE_AGENTS else f"`{name}`"
        rows.append(
            [
                label,
                "–" if name in REACTIVE_AGENTS else str(clean[name].runs),
                interval(clean[name].rate, clean[name].low, clean[name].high),
                *(
                    f"{interval(c.rate, c.low, c.high)} ({delta(c.rate - clean[name].rate)})"
                    for c in (density[name], speed[name])
                ),
                "yes" if ok else "no",
            ]
        )
    header = ["config or agent", "seeds", "clean failure [95 % CI]", f"density {ROBUSTNESS_DENSITY:g} (Δ)"]
    header += [f"{ROBUSTNESS_SPEED:g} m/s (Δ)", f"within +{ROBUSTNESS_MAX_RISE:.2f} at both"]
    return markdown_table(header, rows), within


def _winner_training_values(data: BenchmarkData) -> Values:
    """The winner's two training stages: the second's length and both learning rates."""
    stage1, stage2 = data.training[WINNER].init_config or {}, data.training[WINNER].config
    return {
        "stage2_steps": count(stage2["total_timesteps"]),
        "stage2_lr": learning_rate(stage2["ppo"]["learning_rate"]),
        "stage1_lr": learning_rate(stage1.get("ppo", {}).get("learning_rate", float("nan"))),
    }


def _randomized(config: dict[str, Any]) -> str:
    units = {
        "forward_speed": ("speeds", " m/s"),
        "obstacle_density": ("densities", ""),
        "brightness": ("brightness", ""),
    }
    parts = []
    for key, (low, high) in (config.get("randomize") or {}).items():
        noun, unit = units.get(key, (key, ""))
        parts.append(f"{noun} {low:g}{VSEP}{high:g}{unit}")
    return join_words(parts)


def setup_values(data: BenchmarkData) -> Values:
    """The task's and training's settings, read from the env's defaults, the seed ranges and the shipped
    policies' configs and records."""
    defaults = {f.name: f.default for f in dataclasses.fields(EnvSettings)}
    rows, columns = defaults["histogram_sectors"]
    ppo = data.training["ppo_flow"].config
    learned = [a for a in data.training if a != WINNER]
    stage1 = data.training[WINNER].init_config or {}
    train_lines = []
    for agent in learned:
        seeds = seed_list([int(r["train_seed"]) for r in data.seed_rows if r["agent"] == agent])
        train_lines += [
            f"flownav train --config configs/{agent}.yaml --seeds {seeds} --parallel 2 --ship",
            f"flownav select --config configs/{agent}.yaml --seeds {seeds} --ship",
        ]
    winner_seeds = [int(r["train_seed"]) for r in data.seed_rows if r["agent"] == WINNER]
    return {
        "capsule_height": f"{defaults['obstacle_height']:g}",
        "capsule_radius": f"{defaults['obstacle_radius']:g}",
        "density": f"{defaults['obstacle_density']:g}",
        "field_length": f"{defaults['field_length']:g}",
        "default_speed": f"{defaults['forward_speed']:g}",
        "metres_per_frame": f"{defaults['forward_speed'] / defaults['frame_rate']:g}",
        "frame_rate": f"{defaults['frame_rate']:g}",
        "camera": f"{defaults['camera_width']}×{defaults['camera_height']}",
        "fov": f"{defaults['camera_fov_deg']:g}",
        "histogram": f"{rows} × {columns}-sector × {len(defaults['depth_bin_edges']) - 1}-bin",
        "validation_start": count(VALIDATION_SEED_START),
        "test_start": count(TEST_SEED_START),
        "ablation_start": count(ABLATION_SEED_START),
        "net_arch": " × ".join(map(str, ppo["ppo"]["net_arch"])),
        "ppo_steps": count(ppo["total_timesteps"]),
        "ppo_minutes": span([m for a in learned for m in data.training[a].minutes]),
        "ppo_cores": "/".join(map(str, sorted({c for a in learned for c in data.training[a].cores}))),
        "stage1_steps": count(stage1.get("total_timesteps", 0)),
        "stage1_randomize": _randomized(stage1),
        "stage2_randomize": _randomized(data.training[WINNER].config),
        "train_commands": "\n".join(train_lines),
        "winner_seeds": seed_list(winner_seeds),
    }
