"""The flow-gap targets as ``benchmark.md``, the README's results block and the thesis's closed-loop paragraph
word them (:mod:`agents.reports.benchmark_report` gathers these values with the others): the levers and the
reactive references on validation layouts, clean and at the robustness density and speed, and who meets each
target on test layouts."""

from __future__ import annotations

from dataclasses import dataclass

from agents.analysis.episode_record import is_flow_agent
from agents.common.jinja_reports import rate
from agents.common.study_choices import choices
from agents.common.tables import markdown_table
from agents.evaluation.leaderboard import LeaderboardRow
from agents.pages.wording import display_name, span
from agents.policies.base import REACTIVE_AGENTS
from agents.studies.benchmark_data import BenchmarkData


def _interval(point: float, low: float, high: float) -> str:
    return f"{point:.2f} [{low:.2f}, {high:.2f}]"


def _validation_order(data: BenchmarkData) -> list[str]:
    """The agents flown clean and in both validation conditions, learned ones first, then the reactive ones."""
    clean, density, speed = (data.validation[k] for k in ("clean", "density", "speed"))
    names = [n for n in clean if n in density and n in speed]
    return [n for n in names if n not in REACTIVE_AGENTS] + [n for n in names if n in REACTIVE_AGENTS]


def _validation_row(data: BenchmarkData, name: str, within: bool) -> list[str]:
    """One agent's validation row: its clean failure, each condition's with its rise, whether both stay within."""
    clean = data.validation["clean"][name]
    reactive = name in REACTIVE_AGENTS
    return [
        f"`{name}` (reactive)" if reactive else f"`{name}`",
        "–" if reactive else str(clean.runs),
        _interval(clean.rate, clean.low, clean.high),
        *(
            f"{_interval(r.rate, r.low, r.high)} ({r.rate - clean.rate:+.2f})"
            for r in (data.validation["density"][name], data.validation["speed"][name])
        ),
        "yes" if within else "no",
    ]


def _layouts_per_run(data: BenchmarkData) -> dict[str, set[int]]:
    """Each validation condition's layouts per training run (one value where every agent flew alike)."""
    return {k: {r.episodes // r.runs for r in data.validation[k].values()} for k in data.validation}


@dataclass(frozen=True)
class ValidationValues:
    """The flow-gap levers and the reactive references on validation layouts (:func:`validation_values`), and the
    winner's two training stages' settings the reports state beside them."""

    validation_table: str
    validation_within: list[str]
    validation_clean_layouts: list[int]
    validation_condition_layouts: list[int]
    validation_ok: dict[str, bool]
    stage2_steps: int
    stage2_lr: float
    stage1_lr: float


def validation_values(data: BenchmarkData) -> ValidationValues:
    """The flow-gap levers and the reactive references on validation layouts: clean, at the robustness density
    and speed, each with its difference from clean and whether both rises stay within the limit."""
    c = choices()
    clean, density, speed = (data.validation[k] for k in ("clean", "density", "speed"))
    names = _validation_order(data)
    within = [n for n in names if max(density[n].rate, speed[n].rate) - clean[n].rate <= c.max_rise]
    rows = [_validation_row(data, name, name in within) for name in names]
    header = ["config or agent", "seeds", "clean failure [95 % CI]", f"density {c.robustness_density:g} (Δ)"]
    header += [f"{c.robustness_speed:g} m/s (Δ)", f"within +{c.max_rise:.2f} at both"]
    per_run = _layouts_per_run(data)
    stage1, stage2 = data.training[c.winner].init_config or {}, data.training[c.winner].config
    return ValidationValues(
        validation_table=markdown_table(header, rows),
        validation_within=[f"`{n}`" for n in within],
        validation_clean_layouts=sorted(per_run["clean"]),
        validation_condition_layouts=sorted(per_run["density"] | per_run["speed"]),
        validation_ok={n: n in within for n in names},
        stage2_steps=stage2["total_timesteps"],
        stage2_lr=stage2["ppo"]["learning_rate"],
        stage1_lr=stage1.get("ppo", {}).get("learning_rate", float("nan")),
    )


def _test_rises(data: BenchmarkData) -> dict[str, list[float]]:
    """Each agent's failure rise over its clean test failure (of the training runs the sweep flew) at the
    robustness speed, then density; an agent the sweep did not fly at both is left out."""
    c = choices()
    rise = {}
    for row in data.leaderboard:
        try:
            cells = [data.cell(row["agent"], "forward_speed", c.robustness_speed)]
            cells.append(data.cell(row["agent"], "obstacle_density", c.robustness_density))
            clean = data.sweep_clean[data.sweep_name(row["agent"])].rate
        except KeyError:
            continue
        rise[row["agent"]] = [cell.rate - clean for cell in cells]
    return rise


def _first_target_met(data: BenchmarkData) -> list[LeaderboardRow]:
    """The flow agents (neither ``straight`` nor the oracle) within the first target's failure limit."""
    c = choices()
    limit = min(c.max_failure, c.oracle_factor * data.row("ppo_oracle")["failure_rate"])
    others = ("straight", "ppo_oracle")
    return [
        r
        for r in data.leaderboard
        if is_flow_agent(r) and r["agent"] not in others and r["failure_rate"] <= limit
    ]


@dataclass(frozen=True)
class TargetValues:
    """The flow-gap targets on test layouts (:func:`target_values`): the agents meeting each, and the winner's
    verdict on all three."""

    first_target_met: list[str]
    rise: dict[str, list[float]]
    rise_members: list[str]
    robust_agents: list[str]
    winner_minutes: str
    winner_cores: str
    winner_in_time: bool
    targets_met: bool
    winner_missed: list[str]
    test_ok: dict[str, bool]


def target_values(data: BenchmarkData) -> TargetValues:
    """The flow-gap targets on test layouts: who meets the first target's failure limit, each sweep agent's rise
    at the robustness speed and density over its clean failure, and the winner's training time."""
    c = choices()
    rise = _test_rises(data)
    first = _first_target_met(data)
    test_ok = {a: max(rises) <= c.max_rise for a, rises in rise.items()}
    robust = [a for a, ok in test_ok.items() if ok]
    minutes = data.training[c.winner].minutes
    in_time = max(minutes) <= c.budget_minutes
    met = {
        "the first target's failure limit": data.row(c.winner) in first,
        "the robustness limit": c.winner in robust,
        f"the time limit of {c.budget_minutes:g} min per seed, its slowest seed taking {max(minutes):.0f}": in_time,
    }
    return TargetValues(
        first_target_met=[f"{display_name(r['agent'])} ({rate(r['failure_rate'])})" for r in first],
        rise=rise,
        rise_members=[display_name(a) for a in rise],
        robust_agents=[display_name(a) for a in robust],
        winner_minutes=span(minutes),
        winner_cores="/".join(map(str, data.training[c.winner].cores)),
        winner_in_time=in_time,
        targets_met=all(met.values()),
        winner_missed=[target for target, ok in met.items() if not ok],
        test_ok=test_ok,
    )
