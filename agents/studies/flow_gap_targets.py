"""The flow-gap targets on test layouts, as report values: the flow–truth gap, the first target's failure limit,
the robustness limit at a faster and a denser course, and the winner's training time against its budget."""

from __future__ import annotations

from agents.studies.benchmark_claims import (
    WINNER,
    delta,
    display_name,
    every_or_all_but,
    join_words,
    paired_reading,
    rate,
)
from agents.studies.benchmark_data import BenchmarkData
from agents.studies.benchmark_values import (
    ROBUSTNESS_DENSITY,
    ROBUSTNESS_MAX_RISE,
    ROBUSTNESS_SPEED,
    TARGET_MAX_FAILURE,
    TARGET_ORACLE_FACTOR,
    TRAINING_BUDGET_MINUTES,
    Values,
    span,
)
from agents.studies.error_analysis import is_flow_agent


def robustness(data: BenchmarkData) -> dict[str, tuple[float, float]]:
    """Per sweep agent (base name): its failure at the robustness speed and density on the sweep's test cells, less
    its clean failure on the leading table's layouts."""
    found = {}
    for row in data.leaderboard:
        agent = row["agent"]
        try:
            cells = [
                data.cell(agent, f, x)
                for f, x in (("forward_speed", ROBUSTNESS_SPEED), ("obstacle_density", ROBUSTNESS_DENSITY))
            ]
        except KeyError:
            continue
        found[agent] = (cells[0].rate - row["failure_rate"], cells[1].rate - row["failure_rate"])
    return found


def flow_gap_target_values(data: BenchmarkData) -> Values:
    """The flow-gap targets on test layouts: the flow–truth gap, who meets the first target, who stays within the
    robustness limit, and the winner's training time."""
    first, winner_first = _first_target_values(data)
    robust, winner_robust = _robustness_target_values(data)
    training = _training_time_values(data)
    in_time = training["winner_in_time"] is True
    # ppo_oracle is ppo_flow's twin on true depths: the two differ only in what the policy reads.
    flow_gap = data.compare("ppo_flow", "ppo_oracle")
    return {
        "flow_vs_oracle": paired_reading(flow_gap),
        "flow_costs_nothing": flow_gap.fails_less != "ppo_oracle",
        **first,
        **robust,
        **training,
        "targets_met": winner_first and winner_robust and in_time,
    }


def _first_target_values(data: BenchmarkData) -> tuple[Values, bool]:
    """The flow agents at or below the first target's failure limit, and whether the winner is one."""
    oracle = data.row("ppo_oracle")
    limit = min(TARGET_MAX_FAILURE, TARGET_ORACLE_FACTOR * oracle["failure_rate"])
    flow_agents = [
        r
        for r in data.leaderboard
        if is_flow_agent(r) and r["agent"] != "straight" and r["agent"] != "ppo_oracle"
    ]
    first = [r for r in flow_agents if r["failure_rate"] <= limit]
    values: Values = {
        "target_max_failure": f"{TARGET_MAX_FAILURE:.2f}",
        "target_oracle_factor": f"{TARGET_ORACLE_FACTOR:g}",
        "oracle_rate": rate(oracle["failure_rate"]),
        "first_target_met": join_words(
            [f"{display_name(r['agent'])} ({rate(r['failure_rate'])})" for r in first]
        )
        or "no agent",
    }
    return values, data.row(WINNER) in first


def _robustness_target_values(data: BenchmarkData) -> tuple[Values, bool]:
    """Each sweep agent's rise at the robustness speed and density, who stays within the limit at both, and
    whether the winner does."""
    losses = robustness(data)
    robust = [a for a, (s, d) in losses.items() if s <= ROBUSTNESS_MAX_RISE and d <= ROBUSTNESS_MAX_RISE]
    values: Values = {
        "robustness_lines": "; ".join(
            f"{display_name(a)} {delta(s)} and {delta(d)}" for a, (s, d) in losses.items()
        ),
        "robust_agents": every_or_all_but(
            [display_name(a) for a in losses], [display_name(a) for a in robust], "agent"
        ),
    }
    return values, WINNER in robust


def _training_time_values(data: BenchmarkData) -> Values:
    """The winner's training minutes per seed against the budget."""
    minutes = data.training[WINNER].minutes
    return {
        "winner_minutes": span(minutes),
        "winner_cores": "/".join(map(str, data.training[WINNER].cores)),
        "winner_in_time": max(minutes) <= TRAINING_BUDGET_MINUTES,
        "budget_minutes": f"{TRAINING_BUDGET_MINUTES:.0f}",
    }
