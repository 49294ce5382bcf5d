"""What the sweep says, computed: the values of the benchmark's findings (the winner against ``ppo_flow``, the
thesis's error model, scale errors, direct depth errors, speed, darkness) and of the dose-response summary."""

from __future__ import annotations

from typing import Any

from agents.common.tables import markdown_table
from agents.studies.benchmark_claims import (
    WINNER,
    agents_broken_by,
    delta,
    display_name,
    every_or_all_but,
    level_text,
    rate,
)
from agents.studies.benchmark_data import BenchmarkData
from agents.studies.benchmark_sweep import (
    CENTRING_RULES,
    DIRECT_DEPTH,
    MATERIAL,
    SPEEDS,
    THESIS_MAX_RELATIVE,
    TOLD_ROTATION,
    breaks_sentence,
    sweep_agents,
    sweep_table,
)
from agents.studies.benchmark_values import Values
from agents.studies.error_analysis import P_VALUE_FLOOR, format_p, neutral_level

FLOW = "ppo_flow@all"
WINNER_POOLED = f"{WINNER}@all"
SIGNIFICANT = 0.05


def _levels(data: BenchmarkData, factor: str) -> list[float]:
    return sorted({key[2] for key in data.cells if key[1] == factor})


def _breaking(data: BenchmarkData, agent: str, factor: str, side: str = "above") -> float | None:
    row = data.tolerance_row(agent, factor, side)
    return None if row is None else row["breaking_level"]


def _later(first: float | None, second: float | None) -> bool:
    """Whether breaking at ``first`` comes later (farther out, or never) than at ``second`` (above the neutral
    level)."""
    if first is None:
        return second is not None
    return second is not None and first > second


def _break_text(level: float | None, unit: str = "") -> str:
    return "no level flown" if level is None else level_text(level, unit)


def _pct(level: float | None) -> str:
    return "no level flown" if level is None else f"{100 * level:.0f} %"


# One sweep cell where both the winner and ppo_flow flew: (factor, level, the winner's cell, ppo_flow's cell).
Pair = tuple[str, float, Any, Any]


def winner_values(data: BenchmarkData) -> Values:
    """The winner against ``ppo_flow`` in the sweep: task factors, direct depth errors, and the cells
    where it fails materially more."""
    pairs = _winner_pairs(data)
    return {**_task_break_values(data), **_direct_depth_values(pairs), **_worse_cell_values(data, pairs)}


def _winner_pairs(data: BenchmarkData) -> list[Pair]:
    """Every sweep cell off the clean course that both the winner and ``ppo_flow`` (pooled) flew."""
    return [
        (key[1], key[2], data.cells[(WINNER_POOLED, *key[1:])], data.cells[key])
        for key in sorted(data.cells)
        if key[0] == FLOW and key[1] != "clean" and (WINNER_POOLED, *key[1:]) in data.cells
    ]


def _task_break_values(data: BenchmarkData) -> Values:
    """Where speed and density break the winner and ``ppo_flow``, and whether the winner holds out longer at
    both."""
    speed = {a: _breaking(data, a, "forward_speed") for a in (FLOW, WINNER_POOLED)}
    density = {a: _breaking(data, a, "obstacle_density") for a in (FLOW, WINNER_POOLED)}
    return {
        "winner_holds_task": _later(speed[WINNER_POOLED], speed[FLOW])
        and _later(density[WINNER_POOLED], density[FLOW]),
        "winner_speed_break": _break_text(speed[WINNER_POOLED], "m/s"),
        "winner_density_break": _break_text(density[WINNER_POOLED]),
        "flow_speed_break": _break_text(speed[FLOW], "m/s"),
        "flow_density_break": _break_text(density[FLOW]),
    }


def _direct_depth_values(pairs: list[Pair]) -> Values:
    """The direct depth error cells where the winner fares worst and best against ``ppo_flow``."""
    depth = [(f, x, w.rate - p.rate, w, p) for f, x, w, p in pairs if f in DIRECT_DEPTH]
    worst, best = max(depth, key=lambda d: d[2]), min(depth, key=lambda d: d[2])
    return {"depth_worst": _compared(worst), "depth_best": _compared(best)}


def _compared(item: tuple[str, float, float, Any, Any]) -> str:
    factor, level, difference, mine, theirs = item
    side = "more" if difference >= 0 else "less"
    return (
        f"{abs(difference):.2f} {side} than `ppo_flow` (`{factor}` {level:g}: {rate(mine.rate)} against "
        f"{rate(theirs.rate)})"
    )


def _worse_cell_values(data: BenchmarkData, pairs: list[Pair]) -> Values:
    """The cells where the winner fails materially more than ``ppo_flow``, and whether only told rotation
    errors do it."""
    worse = [(f, x, w, p) for f, x, w, p in pairs if w.rate - p.rate >= MATERIAL]
    return {
        "any_worse": bool(worse),
        "rotation_only": bool(worse) and all(f in TOLD_ROTATION for f, *_ in worse),
        "material": f"{MATERIAL:.2f}",
        "winner_worse_cells": ", ".join(
            f"`{f}` {x:g} ({rate(w.rate)} against {rate(p.rate)})" for f, x, w, p in worse
        ),
        "worse_clear_note": _clear_note(data, worse),
    }


def _clear_note(data: BenchmarkData, worse: list[Pair]) -> str:
    """Which of the worse cells have the two intervals apart; empty when none is worse or all are apart."""
    clear = [f"`{f}` {x:g}" for f, x, w, p in worse if w.low > p.high]
    if not worse or len(clear) == len(worse):
        return ""
    if clear:
        return f" (clear of both intervals: {', '.join(clear)})"
    return f" (none of these differences is clear of both intervals on {next(iter(data.cells.values())).episodes} layouts)"


def thesis_model_values(data: BenchmarkData) -> Values:
    """The thesis's relative error model against an absolute noise floor."""
    table = sweep_table(data)
    relative = [r["breaking_level"] for r in table if r["factor"] in ("rotation_error", "translation_error")]
    first = min((x for x in relative if x is not None), default=None)
    floors = _levels(data, "rotation_noise_deg")
    broken, unbroken = agents_broken_by(table, "rotation_noise_deg", floors[0])
    flow_rot, flow_trans = (_breaking(data, FLOW, f) for f in ("rotation_error", "translation_error"))
    return {
        "relative_mild": first is None or first > THESIS_MAX_RELATIVE,
        "floor_harsher": len(broken) >= len(unbroken),
        "thesis_max_pct": f"{100 * THESIS_MAX_RELATIVE:.0f}",
        "flow_relative": f"{_pct(flow_rot)} of the frame's rotation and {_pct(flow_trans)} of its translation",
        "relative_first_break": _pct(first).removesuffix(" %"),
        "turn_median": f"{data.thesis_motion['rotation_deg_median']:.1f}",
        "floor_low": level_text(floors[0], "°"),
        "floor_low_sentence": breaks_sentence(data, "rotation_noise_deg", floors[0]),
        "floor_high": level_text(floors[-1], "°"),
        "floor_high_sentence": breaks_sentence(data, "rotation_noise_deg", floors[-1]),
    }


def _signed_pct(level: float) -> str:
    return f"{100 * level:+.0f} %"


def scale_values(data: BenchmarkData) -> Values:
    """Translation scale errors and drift; direct depth noise and outliers."""
    table = sweep_table(data)
    biases, drifts = _levels(data, "translation_bias"), _levels(data, "translation_drift")
    low = biases[0]
    broken, _ = agents_broken_by(table, "translation_bias", low)
    rules = [f"{a}" for a in CENTRING_RULES]
    noise = _levels(data, "depth_noise")
    noise_level = _breaking(data, FLOW, "depth_noise") or noise[-1]
    held, _ = agents_broken_by(table, "depth_noise", noise[-1])
    outliers = _levels(data, "depth_outliers")
    outlier_level = _breaking(data, FLOW, "depth_outliers") or outliers[-1]
    return {
        "scale_spares_rules": FLOW in broken and not set(rules) & set(broken),
        "tb_low": _signed_pct(low),
        "tb_low_sentence": breaks_sentence(data, "translation_bias", low),
        "tb_flow": rate(data.cell("ppo_flow", "translation_bias", low).rate),
        "tb_ttc": rate(data.cell("bee_ttc", "translation_bias", low).rate),
        "tb_robust": rate(data.cell("bee_robust", "translation_bias", low).rate),
        "tb_high": _signed_pct(biases[-1]),
        "tb_high_sentence": breaks_sentence(data, "translation_bias", biases[-1]),
        "td_low": f"{drifts[0]:g}",
        "td_low_sentence": breaks_sentence(data, "translation_drift", drifts[0]),
        "td_high": f"{drifts[-1]:g}",
        "td_high_sentence": breaks_sentence(data, "translation_drift", drifts[-1]),
        "dn_level": f"{noise_level:g}",
        "dn_sentence": breaks_sentence(data, "depth_noise", noise_level),
        "rules_hold_noise": not set(rules) & set(held),
        "dn_max": f"{noise[-1]:g}",
        "rules_noise_worst": " and ".join(
            f"`{a}` {rate(data.cell(a, 'depth_noise', noise[-1]).rate)}" for a in rules
        ),
        "outlier_pct": f"{100 * outlier_level:.0f}",
        "outlier_sentence": breaks_sentence(data, "depth_outliers", outlier_level),
    }


def task_values(data: BenchmarkData) -> Values:
    """Speed and darkness."""
    agents = ["bee_ttc", "bee_robust", "ppo_flow", WINNER]

    def rates(speed: float) -> str:
        parts = [f"{display_name(a)} {rate(data.cell(a, 'forward_speed', speed).rate)}" for a in agents]
        parts[0] = parts[0].replace(" ", " fails ", 1)
        return ", ".join(parts)

    slow = _levels(data, "forward_speed")[0]
    dark = [x for x in _levels(data, "brightness") if x < neutral_level("brightness")]
    return {
        "speed_a": f"{SPEEDS[0]:g}",
        "speed_a_rates": rates(SPEEDS[0]),
        "speed_b": f"{SPEEDS[1]:g}",
        "speed_b_rates": rates(SPEEDS[1]),
        "slow": f"{slow:g}",
        "slow_per_frame": f"{slow / neutral_level('frame_rate'):g}",
        "slow_sentence": breaks_sentence(data, "forward_speed", slow),
        "dark": f"{dark[-1]:g}",
        "dark_sentence": breaks_sentence(data, "brightness", dark[-1]),
    }


def _term(fit: dict[str, Any], name: str) -> str:
    if name not in fit["params"]:
        return "–"
    return f"{delta(fit['params'][name])} (p {format_p(fit['pvalues'][name])})"


def dose_values(data: BenchmarkData) -> Values:
    """The dose-response fits per agent, and which agents each depth measure significantly moves."""
    agents = [a for a in sweep_agents(data) if a in data.fits]
    fits = {a: data.fits[a] for a in agents}
    rows = [
        [
            display_name(a),
            str(fit["episodes"]),
            *(_term(fit, t) for t in ("log_depth_error", "valid_points_per_100", "outlier_share")),
            f"{fit['wald_statistic']:.1f} on {fit['wald_df']} df (p {format_p(fit['wald_pvalue'])})",
        ]
        for a, fit in fits.items()
    ]
    header = [
        "agent",
        "episodes",
        "per e-fold of depth error",
        "per 100 valid depths",
        "per unit outlier share",
    ]
    table = markdown_table([*header, "sensor factors beyond quality (Wald)"], rows)
    if data.fit_errors:
        table += "\n\n" + " ".join(f"No fit for {display_name(a)}: {e}." for a, e in data.fit_errors.items())

    def moved(term: str, sign: float) -> str:
        chosen = [
            display_name(a)
            for a, fit in fits.items()
            if term in fit["params"] and fit["params"][term] * sign > 0 and fit["pvalues"][term] < SIGNIFICANT
        ]
        return every_or_all_but([display_name(a) for a in fits], chosen)

    adding = [display_name(a) for a, fit in fits.items() if fit["wald_pvalue"] < SIGNIFICANT]
    return {
        "p_floor": f"{P_VALUE_FLOOR:g}",
        "dose_table": table,
        "error_claim": moved("log_depth_error", 1.0),
        "valid_claim": moved("valid_points_per_100", -1.0),
        "outlier_claim": moved("outlier_share", 1.0),
        "factors_add_all": len(adding) == len(fits),
        "factors_add_claim": every_or_all_but([display_name(a) for a in fits], adding),
        "wald_p_max": format_p(max(fit["wald_pvalue"] for fit in fits.values())),
    }
