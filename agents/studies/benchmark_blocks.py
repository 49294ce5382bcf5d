"""The values of the two generated blocks in hand-written files: the README's results (its table and the
comparisons its bullets make) and the thesis discussion's closed-loop paragraph."""

from __future__ import annotations

from agents.common.tables import markdown_table
from agents.policies.base import REACTIVE_AGENTS
from agents.studies.benchmark_claims import WINNER, interval, paired_reading, rate
from agents.studies.benchmark_data import BenchmarkData
from agents.studies.benchmark_findings import FLOW
from agents.studies.benchmark_sweep import sweep_table
from agents.studies.benchmark_values import (
    DESCRIPTIONS,
    ROBUSTNESS_MAX_RISE,
    Values,
    best_agents,
)
from agents.studies.flow_gap_targets import robustness

_NUMBER_WORDS = (
    "no",
    "one",
    "two",
    "three",
    "four",
    "five",
    "six",
    "seven",
    "eight",
    "nine",
    "ten",
    "eleven",
)


def _suite_top_lines(data: BenchmarkData) -> str:
    """A line per suite tier: its top group by the paired tests, and its best ranked agent's failure."""
    return "\n".join(
        f"- `{t['tier']}`: top group {', '.join(f'`{a}`' for a in t['top_group'])}; best `{t['best']}`, failure "
        f"{rate(t['best_failure'])}"
        for t in data.suite_top
    )


def _readme_table(data: BenchmarkData) -> str:
    best_reactive, best_learned = best_agents(data)
    bold = {best_reactive["agent"], best_learned["agent"]}
    rows = []
    for r in data.leaderboard:
        label = f"{DESCRIPTIONS.get(r['agent'], r['agent'])} (`{r['agent']}`)"
        failure = interval(r["failure_rate"], r["failure_low"], r["failure_high"])
        if r["agent"] in bold:
            label, failure = f"**{label}**", f"**{failure}**"
        runs = "–" if r["agent"] in REACTIVE_AGENTS else str(r["runs"])
        rates = (rate(r[key]) for key in ("collision_rate", "out_of_bounds_rate", "success_rate"))
        rows.append([label, runs, failure, *rates])
    header = [
        "agent",
        "training runs",
        "failure rate [95 % CI]",
        "collision",
        "out of bounds",
        "success rate",
    ]
    return markdown_table(header, rows)


def _beat_sentence(data: BenchmarkData) -> str:
    """``ppo_flow`` against the plain ``bee`` and ``vfh``, paired by layout (``ppo_oracle``, privileged, is a
    reference and not set against the rules)."""
    readings = [paired_reading(data.compare("ppo_flow", rule)) for rule in ("bee", "vfh")]
    return f"Against the plain rules: {readings[0]}; {readings[1]}."


def readme_values(data: BenchmarkData) -> Values:
    """The README's own values: its table and the comparisons its bullets make."""
    flow_vs_rules = "; ".join(paired_reading(data.compare("ppo_flow", a)) for a in ("bee_robust", "bee_ttc"))
    test_ok = {a: max(losses) <= ROBUSTNESS_MAX_RISE for a, losses in robustness(data).items()}
    clean, density, speed = (data.validation[c] for c in ("clean", "density", "speed"))
    validation_ok = {
        name: max(density[name].rate, speed[name].rate) - clean[name].rate <= ROBUSTNESS_MAX_RISE
        for name in set(clean) & set(density) & set(speed) & set(test_ok)
    }
    bias = data.tolerance_row(WINNER, "rotation_bias", "above")
    level = bias["breaking_level"] if bias and bias["breaking_level"] is not None else max(bias["levels"])
    rb = {
        a: " / ".join(rate(data.cell(a, "rotation_bias", sign * level).rate) for sign in (1, -1))
        for a in ("ppo_flow", WINNER)
    }
    robust = data.row("ppo_robust")
    robust_vs_flow = data.compare("ppo_robust", "ppo_flow")
    oracle = data.oracle_reactive
    return {
        "suite_top_lines": _suite_top_lines(data),
        "readme_table": _readme_table(data),
        **{
            f"r_{a}": rate(data.row(a)["failure_rate"])
            for a in ("bee_robust", "bee_ttc", "ppo_flow", "ppo_oracle", "ppo_robust")
        },
        "flow_vs_rules": flow_vs_rules,
        "oracle_ttc": interval(oracle["bee_ttc"].rate, oracle["bee_ttc"].low, oracle["bee_ttc"].high),
        "oracle_robust": interval(
            oracle["bee_robust"].rate, oracle["bee_robust"].low, oracle["bee_robust"].high
        ),
        "ppo_beat_sentence": _beat_sentence(data),
        "validation_agrees": all(validation_ok[a] == test_ok[a] for a in validation_ok),
        "rb_pct": f"{100 * level:.0f}",
        "rb_winner": rb[WINNER],
        "rb_flow": rb["ppo_flow"],
        "robust_costs": robust_vs_flow.fails_less == "ppo_flow",
        "robust_vs_flow": paired_reading(robust_vs_flow),
        "robust_oob": rate(robust["out_of_bounds_rate"]),
    }


def _broke(
    data: BenchmarkData, agent: str, factor: str, side: str = "above", signed: bool = False
) -> tuple[str, ...]:
    """Where ``factor`` first breaks ``agent`` on ``side`` (a percentage), its clean failure and its failure
    there."""
    row = data.tolerance_row(agent, factor, side)
    if row is None:
        return "not flown", "–", "–"
    if row["breaking_level"] is None:
        return "no level flown", rate(row["clean_failure"]), "–"
    level = f"{100 * row['breaking_level']:{'+' if signed else ''}.0f} %"
    return level, rate(row["clean_failure"]), rate(row["breaking_failure"])


def thesis_values(data: BenchmarkData) -> Values:
    """The thesis discussion's closed-loop values: the relative rotation error's and the rotation bias's
    breaking points, beside the clean rates."""
    first = min(
        (
            r["breaking_level"]
            for r in sweep_table(data)
            if r["factor"] == "rotation_error" and r["breaking_level"] is not None
        ),
        default=None,
    )
    flow, ttc = _broke(data, FLOW, "rotation_error"), _broke(data, "bee_ttc", "rotation_error")
    bias = [_broke(data, FLOW, "rotation_bias", side, signed=True) for side in ("above", "below")]
    agents = len({key[0] for key in data.cells})
    return {
        "sweep_agent_words": _NUMBER_WORDS[agents] if agents < len(_NUMBER_WORDS) else str(agents),
        "rotation_first_break": "no level flown" if first is None else f"{100 * first:.0f}",
        "flow_rotation_pct": flow[0],
        "flow_clean": flow[1],
        "flow_rotation_rate": flow[2],
        "ttc_rotation_pct": ttc[0],
        "ttc_clean": ttc[1],
        "ttc_rotation_rate": ttc[2],
        "flow_bias_break": " and ".join(f"{level} ({failure})" for level, _, failure in bias),
    }
