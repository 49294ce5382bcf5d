"""The values of the benchmark's sweep sections: its size and provenance, where each factor breaks the agents,
what the findings compare (the winner against ``ppo_flow``, the thesis's error model, scale and direct depth
errors, speed, darkness) and the dose-response fits. Each claim is a list of the agents it holds for; the
template words it."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from agents.policies.base import base_agent_name
from agents.studies.benchmark_data import BenchmarkData, Rate, choices, commit_of
from agents.studies.dose_response import P_VALUE_FLOOR, format_p
from agents.studies.error_analysis import best_learned_flow_agent, neutral_level, unbroken_kind
from agents.studies.wording import display_name, level_text

FLOW = "ppo_flow@all"
SIGNIFICANT = 0.05
DIRECT_DEPTH = ("depth_noise", "depth_outliers", "depth_dropout")
TOLD_ROTATION = ("rotation_error", "rotation_bias", "rotation_drift", "rotation_noise_deg")
DOSE_TERMS = ("log_depth_error", "valid_points_per_100", "outlier_share")


Values = dict[str, Any]


def sweep_agents(data: BenchmarkData) -> list[str]:
    """The sweep's agents (pooled names) in the leaderboard's order."""
    order = [r["agent"] for r in data.leaderboard]
    rank = {
        name: order.index(base_agent_name(name)) if base_agent_name(name) in order else 99
        for name in {k[0] for k in data.cells}
    }
    return sorted(rank, key=rank.__getitem__)


def broken_agents(data: BenchmarkData, factor: str, level: float) -> tuple[list[str], list[str]]:
    """The agents that flew ``factor`` at ``level``, in the sweep's order, split into those it has broken by then
    (their first breaking level, scanning outward from the neutral level, lies at or before it) and the rest.

    Raises:
        ValueError: no agent flew ``factor`` at ``level``.
    """
    order = sweep_agents(data)
    rows = [r for r in data.tolerance if r["factor"] == factor and level in r["levels"]]
    if not rows:
        raise ValueError(f"no agent in the sweep flew {factor} at {level:g}")
    split: tuple[list[str], list[str]] = ([], [])
    for row in sorted(rows, key=lambda r: order.index(r["agent"])):
        levels, first = list(row["levels"]), row["breaking_level"]
        split[first is None or levels.index(first) > levels.index(level)].append(row["agent"])
    return split


def broken_by(data: BenchmarkData, factor: str, level: float) -> dict[str, Any]:
    """:func:`broken_agents` as the template words it: display names with their failure at ``level``."""
    named = [
        [{"name": display_name(a), "rate": data.cells[(a, factor, float(level))].rate} for a in side]
        for side in broken_agents(data, factor, level)
    ]
    return {"level": level, "broken": named[0], "unbroken": named[1]}


def _levels(data: BenchmarkData, factor: str) -> list[float]:
    return sorted({key[2] for key in data.cells if key[1] == factor})


def _breaking(data: BenchmarkData, agent: str, factor: str, side: str = "above") -> float | None:
    row = data.tolerance_row(agent, factor, side)
    return None if row is None else row["breaking_level"]


def _later(first: float | None, second: float | None) -> bool:
    """Whether breaking at ``first`` comes later (farther out, or never) than at ``second``."""
    return second is not None and (first is None or first > second)


def _breaking_rows(data: BenchmarkData, columns: Sequence[str]) -> list[dict[str, Any]]:
    """Per factor flown, in the study's order: its label, unit and what it is, and each agent of ``columns``'s
    tolerance rows (``templates/benchmark_tables.j2`` words where each breaks)."""
    factors = choices().factors
    speed, frame_rate = neutral_level("forward_speed"), neutral_level("frame_rate")
    flown = {key[1] for key in data.cells} - {"clean"}
    rows = []
    for factor in sorted(flown, key=lambda f: list(factors).index(f) if f in factors else 99):
        label, unit, what = factors.get(factor, [factor, "", ""])
        if factor == "forward_speed":
            what += f" ({speed / frame_rate:g} m at {speed:g} m/s)"
        sides = [[data.tolerance_row(a, factor, side) for side in ("above", "below")] for a in columns]
        rows.append(
            {"label": label, "unit": unit, "what": what, "cells": [list(filter(None, s)) for s in sides]}
        )
    return rows


def _unbroken(data: BenchmarkData, subjects: Sequence[str]) -> tuple[list[dict[str, Any]], bool]:
    """The factors (and sides) that no level flown breaks the subjects at, each with why and the worst rates, and
    whether each of them cannot (flown to the setting's end, or it only makes the task easier)."""
    missed: dict[tuple[str, str], list[dict[str, Any]]] = {}
    order = sweep_agents(data)
    for row in sorted(data.tolerance, key=lambda r: order.index(r["agent"])):
        if row["agent"] in subjects and row["breaking_level"] is None:
            missed.setdefault((row["factor"], row["side"]), []).append(row)
    clauses = [
        {
            "where": f"`{factor}` {side} {neutral_level(factor):g}",
            "who": [display_name(r["agent"]) for r in rows],
            "worst": [r["worst_failure"] for r in rows],
            "kind": unbroken_kind(rows[0]),
            "last": level_text(rows[0]["levels"][-1], choices().factors.get(factor, [factor, "", ""])[1]),
            "farthest": f"{rows[0]['levels'][-1]:g}",
        }
        for (factor, side), rows in missed.items()
    ]
    kinds = {unbroken_kind(r) for rows in missed.values() for r in rows}
    return clauses, kinds <= {"end", "easier"}


def _code_versions(data: BenchmarkData, agents: Sequence[str]) -> list[dict[str, Any]]:
    """The commits the sweep's episodes were flown at, each with the agents it flew (``only``) where they are at
    most half of them, or those it did not (``all_but``) where it flew more."""
    found = []
    for version, n, which in data.sweep_code_versions:
        left = [display_name(a) for a in agents if base_agent_name(a) not in which]
        few = len(which) <= len(agents) / 2 and bool(left)
        only = [display_name(a) for a in which] if few else []
        found.append(
            {"episodes": n, "commit": commit_of(version), "only": only, "all_but": [] if few else left}
        )
    return found


def _pairs(data: BenchmarkData) -> list[tuple[str, float, Rate, Rate]]:
    """Every sweep cell off the clean course that both the winner and ``ppo_flow`` (pooled) flew."""
    winner = f"{choices().winner}@all"
    return [
        (key[1], key[2], data.cells[(winner, *key[1:])], data.cells[key])
        for key in sorted(data.cells)
        if key[0] == FLOW and key[1] != "clean" and (winner, *key[1:]) in data.cells
    ]


def _winner_findings(data: BenchmarkData) -> Values:
    """The winner against ``ppo_flow`` over the sweep: where the task's speed and density break each, the direct
    depth errors it handles worst and best, and the cells where it fails materially more."""
    c = choices()
    pairs = _pairs(data)
    depth = [(w.rate - p.rate, f, x, w, p) for f, x, w, p in pairs if f in DIRECT_DEPTH]
    worse = [
        {"factor": f, "level": x, "mine": w, "theirs": p, "clear": w.low > p.high}
        for f, x, w, p in pairs
        if w.rate - p.rate >= c.material
    ]
    task = {
        name: {f: _breaking(data, agent, f) for f in ("forward_speed", "obstacle_density")}
        for name, agent in (("flow", FLOW), ("winner", f"{c.winner}@all"))
    }
    return {
        "task_breaks": task,
        "winner_holds_task": all(_later(task["winner"][f], task["flow"][f]) for f in task["flow"]),
        "depth_worst": max(depth, key=lambda d: d[0]),
        "depth_best": min(depth, key=lambda d: d[0]),
        "worse": worse,
        "rotation_only": bool(worse) and all(w["factor"] in TOLD_ROTATION for w in worse),
    }


def _first_breaking(rows: Sequence[dict[str, Any]]) -> float | None:
    """The lowest breaking level among tolerance ``rows``; None where none of them breaks."""
    return min((r["breaking_level"] for r in rows if r["breaking_level"] is not None), default=None)


def _relative_findings(data: BenchmarkData) -> Values:
    """Where the thesis's error model (a rotation or translation error relative to the motion) first breaks any
    agent, and ``ppo_flow``."""
    rows = {
        f: [r for r in data.tolerance if r["factor"] == f] for f in ("rotation_error", "translation_error")
    }
    return {
        "rotation_first": _first_breaking(rows["rotation_error"]),
        "relative_first": _first_breaking([r for rs in rows.values() for r in rs]),
        "flow_relative": [_breaking(data, FLOW, f) for f in rows],
    }


def _quoted_levels(data: BenchmarkData) -> dict[str, tuple[str, float]]:
    """The (factor, level) each finding quotes, by name: the ends of the noise floor and of the translation bias
    and drift, where ``ppo_flow`` breaks on depth noise and outliers (the farthest level where it never does),
    the slowest speed and the darkest level flown."""
    levels = {factor: _levels(data, factor) for factor in {key[1] for key in data.cells}}
    floors, noise, outliers = (levels[f] for f in ("rotation_noise_deg", "depth_noise", "depth_outliers"))
    dark = [x for x in levels["brightness"] if x < neutral_level("brightness")][-1]
    return {
        "floor_low": ("rotation_noise_deg", floors[0]),
        "floor_high": ("rotation_noise_deg", floors[-1]),
        "tb_low": ("translation_bias", levels["translation_bias"][0]),
        "tb_high": ("translation_bias", levels["translation_bias"][-1]),
        "td_low": ("translation_drift", levels["translation_drift"][0]),
        "td_high": ("translation_drift", levels["translation_drift"][-1]),
        "dn": ("depth_noise", _breaking(data, FLOW, "depth_noise") or noise[-1]),
        "outlier": ("depth_outliers", _breaking(data, FLOW, "depth_outliers") or outliers[-1]),
        "slow": ("forward_speed", levels["forward_speed"][0]),
        "dark": ("brightness", dark),
    }


def _rule_findings(data: BenchmarkData, quoted: dict[str, tuple[str, float]]) -> Values:
    """What scale, noise and bias errors break: whether the noise floor breaks most agents at its lowest level,
    whether a scale error spares the centring rules that break ``ppo_flow``, whether the rules hold at the most
    depth noise flown, and the rotation bias the winner breaks at (the farthest flown where it never does).

    Raises:
        ValueError: the sweep has no rotation bias above its neutral level for the winner.
    """
    c = choices()
    rules = set(c.centring_rules)
    broken_by_bias = broken_agents(data, *quoted["tb_low"])[0]
    floor = broken_agents(data, *quoted["floor_low"])
    bias = data.tolerance_row(c.winner, "rotation_bias")
    if bias is None:
        raise ValueError("the sweep has no rotation bias above its neutral level for the winner")
    noise_max = _levels(data, "depth_noise")[-1]
    return {
        "floor_harsher": len(floor[0]) >= len(floor[1]),
        "scale_spares_rules": FLOW in broken_by_bias and not rules & set(broken_by_bias),
        "rules_hold_noise": not rules & set(broken_agents(data, "depth_noise", noise_max)[0]),
        "noise_max": noise_max,
        "rb_level": max(bias["levels"]) if bias["breaking_level"] is None else bias["breaking_level"],
    }


def finding_values(data: BenchmarkData) -> Values:
    """The winner against ``ppo_flow`` in the sweep, the thesis's error model against a noise floor, scale and
    direct depth errors, speed and darkness: the levels each finding quotes and who breaks there."""
    quoted = _quoted_levels(data)
    rules = _rule_findings(data, quoted)
    return {
        **_winner_findings(data),
        "cell_episodes": next(iter(data.cells.values())).episodes,
        **_relative_findings(data),
        "turn_median": data.thesis_motion["rotation_deg_median"],
        **{name: broken_by(data, factor, level) for name, (factor, level) in quoted.items()},
        **rules,
        "thesis_rows": {
            "flow_rotation": data.tolerance_row(FLOW, "rotation_error"),
            "ttc_rotation": data.tolerance_row("bee_ttc", "rotation_error"),
            "flow_bias": [data.tolerance_row(FLOW, "rotation_bias", side) for side in ("above", "below")],
        },
    }


def sweep_values(data: BenchmarkData) -> Values:
    """The sweep's size, provenance, clean references, breaking table, findings and dose-response fits."""
    agents = sweep_agents(data)
    clean = {r["agent"]: r["clean_failure"] for r in data.tolerance}
    subjects = [FLOW, best_learned_flow_agent(data.tolerance) or f"{choices().winner}@all"]
    unbroken, cannot = _unbroken(data, subjects)
    columns = [*subjects, data.best_agents()[0]["agent"]]
    return {
        "sweep_episodes": len(data.sweep_rows),
        "per_cell": sorted({cell.episodes for cell in data.cells.values()}),
        "sweep_layouts": sorted({int(r["seed"]) for r in data.sweep_rows}),
        "sweep_cell_count": len({key[1:] for key in data.cells}),
        "sweep_factor_count": len({key[1] for key in data.cells} - {"clean"}),
        "sweep_level_count": len({key[1:] for key in data.cells if key[1] != "clean"}),
        "sweep_agent_count": len(agents),
        "sweep_learned": [
            f"{display_name(a)} ({data.sweep_seeds[base_agent_name(a)]} seeds)" for a in agents if "@" in a
        ],
        "sweep_code": _code_versions(data, agents),
        "clean_list": [
            (display_name(a), clean[a], data.cells[(a, "clean", 0.0)].rate)
            for a in sorted(clean, key=clean.__getitem__)
        ],
        "subjects": [display_name(a) for a in subjects],
        "unbroken": unbroken,
        "unbroken_cannot": cannot,
        "breaking_columns": columns,
        "breaking_rows": _breaking_rows(data, columns),
        "cell": data.cell,
        **finding_values(data),
        **dose_values(data, agents),
    }


def dose_values(data: BenchmarkData, agents: Sequence[str]) -> Values:
    """The dose-response fits per agent, and which agents each depth measure significantly moves."""
    fits = {a: data.fits[a] for a in agents if a in data.fits}

    def moved(term: str, sign: float) -> list[str]:
        return [
            display_name(a)
            for a, fit in fits.items()
            if term in fit["params"] and fit["params"][term] * sign > 0 and fit["pvalues"][term] < SIGNIFICANT
        ]

    return {
        "p_floor": P_VALUE_FLOOR,
        "fits": fits,
        "dose_terms": DOSE_TERMS,
        "fit_errors": {display_name(a): e for a, e in data.fit_errors.items()},
        "fitted": [display_name(a) for a in fits],
        "moved": {t: moved(t, sign) for t, sign in zip(DOSE_TERMS, (1.0, -1.0, 1.0), strict=True)},
        "factors_add": [display_name(a) for a, fit in fits.items() if fit["wald_pvalue"] < SIGNIFICANT],
        "wald_p_max": format_p(max(fit["wald_pvalue"] for fit in fits.values())),
    }
