"""The values of the benchmark's sweep sections: where each factor breaks the agents, what the sweep says, and
whether depth quality explains the failures. Every claim ("breaks every agent", "never the robust rules") is
computed here from the tolerance table and the sweep's cells."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from agents.common.tables import markdown_table
from agents.policies.base import base_agent_name
from agents.studies.benchmark_claims import (
    WINNER,
    agents_broken_by,
    display_name,
    every_or_all_but,
    join_words,
    level_text,
    rate,
    rate_range,
)
from agents.studies.benchmark_data import BenchmarkData, commit_of
from agents.studies.benchmark_values import VSEP, Values, best_agents, count
from agents.studies.error_analysis import neutral_level
from agents.studies.error_analysis_report import best_learned_flow_agent
from flownav_env.settings_check import setting_range

# Per factor: its label in the breaking table, the unit its levels print with, and what it is.
FACTORS = {
    "rotation_error": (
        "rotation error (per-frame, relative: the thesis's model)",
        "",
        "noise on the told rotation, a share of the frame's own rotation",
    ),
    "translation_error": ("translation error (same, translation)", "", ""),
    "rotation_noise_deg": (
        "rotation noise floor",
        "°",
        "a gyro's noise, present when the drone does not turn",
    ),
    "translation_noise_m": ("translation noise floor", "m", ""),
    "rotation_bias": ("rotation bias (mis-calibration)", "", "a constant scale error per episode"),
    "translation_bias": ("translation bias", "", ""),
    "rotation_drift": ("rotation drift", "", "a random walk of the bias"),
    "translation_drift": ("translation drift", "", ""),
    "depth_noise": ("depth noise (direct, log-normal σ)", "", "in the estimator's own units"),
    "depth_outliers": ("depth outliers (direct, share)", "", ""),
    "depth_dropout": ("depth dropout (direct, share)", "", ""),
    "attitude_jitter_deg": ("attitude jitter", "°", "the thesis's camera instability"),
    "forward_speed": ("forward speed", "m/s", "the thesis's distance per frame"),
    "obstacle_density": ("obstacle density", "", "capsules per m²"),
    "brightness": ("brightness", "", "1 = daylight"),
}
DIRECT_DEPTH = ("depth_noise", "depth_outliers", "depth_dropout")
TOLD_ROTATION = ("rotation_error", "rotation_bias", "rotation_drift", "rotation_noise_deg")
# A difference of failure rates the report calls material: the robustness limit of the flow-gap targets.
MATERIAL = 0.10
# The largest relative per-frame error the thesis tested.
THESIS_MAX_RELATIVE = 0.10
CENTRING_RULES = ("bee_robust", "bee_ttc")
SPEEDS = (1.5, 2.0)


def _unit(factor: str) -> str:
    return FACTORS.get(factor, (factor, "", ""))[1]


def sweep_agents(data: BenchmarkData) -> list[str]:
    """The sweep's agents in the leaderboard's order (pooled names)."""
    names = {key[0] for key in data.cells}
    ordered = [r["agent"] for r in data.leaderboard]
    return sorted(
        names, key=lambda n: ordered.index(base_agent_name(n)) if base_agent_name(n) in ordered else 99
    )


def sweep_table(data: BenchmarkData) -> list[dict[str, Any]]:
    """The tolerance rows in the leaderboard's agent order, so every list of names reads the same way."""
    order = sweep_agents(data)
    return sorted(data.tolerance, key=lambda r: order.index(r["agent"]))


def breaks_sentence(data: BenchmarkData, factor: str, level: float) -> str:
    """ "breaks every agent (0.62–0.91)"; "breaks `a` and `b` (0.22–0.50) but not `c` (0.31)": the claim with the
    failure rates at ``level`` of the agents on each side of it."""
    table = sweep_table(data)
    broken, unbroken = agents_broken_by(table, factor, level)
    members = [display_name(a) for a in broken + unbroken]
    order = [display_name(a) for a in sweep_agents(data) if display_name(a) in members]
    phrase = every_or_all_but(order, [display_name(a) for a in broken])

    def rates(agents: Sequence[str]) -> str:
        return rate_range([data.cells[(a, factor, float(level))].rate for a in agents])

    if not unbroken or not broken:
        return f"breaks {phrase} ({rates(broken + unbroken)})"
    if phrase.startswith("all "):
        rest = "; ".join(f"{display_name(a)} {rates([a])}" for a in unbroken)
        return f"breaks {phrase} ({rates(broken)}; {rest})"
    head, tail = phrase.split(" but not ")
    return f"breaks {head} ({rates(broken)}) but not {tail} ({rates(unbroken)})"


def _break_cell(data: BenchmarkData, agent: str, factor: str) -> str:
    parts = []
    for side in ("above", "below"):
        row = data.tolerance_row(agent, factor, side)
        if row is None:
            continue
        if row["breaking_level"] is None:
            parts.append(
                f"— ({rate(row['worst_failure'])} at {level_text(row['worst_level'], _unit(factor))})"
            )
        else:
            parts.append(
                f"{level_text(row['breaking_level'], _unit(factor))} ({rate(row['breaking_failure'])})"
            )
    return "; ".join(parts)


def _unbroken_kind(row: dict[str, Any]) -> str:
    """Why no level flown breaks an agent: "end" (flown to the setting's range end), "easier" (no level fails
    more than clean) or "short" (more levels are needed)."""
    allowed = setting_range(row["factor"])
    end = allowed.high if row["side"] == "above" else allowed.low
    if math.isclose(row["levels"][-1], end):
        return "end"
    return "easier" if row["worst_failure"] <= row["clean_failure"] else "short"


def _unbroken_headline(data: BenchmarkData, subjects: Sequence[str]) -> str:
    """Which factors fail to break the subjects (``ppo_flow`` and the winner), and why."""
    names = join_words([display_name(a) for a in subjects])
    missed: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for row in sweep_table(data):
        if row["agent"] in subjects and row["breaking_level"] is None:
            missed.setdefault((row["factor"], row["side"]), []).append(row)
    if not missed:
        return f"**Every factor breaks {names} on every side flown.**"
    kinds = {_unbroken_kind(r) for rows in missed.values() for r in rows}
    head = "except where it cannot" if kinds <= {"end", "easier"} else "except"
    clauses = []
    for (factor, side), rows in missed.items():
        who = join_words([display_name(r["agent"]) for r in rows], "or")
        worst = " and ".join(rate(r["worst_failure"]) for r in rows)
        where = f"`{factor}` {side} {neutral_level(factor):g}"
        kind = _unbroken_kind(rows[0])
        if kind == "end":
            end = level_text(rows[0]["levels"][-1], _unit(factor))
            clauses.append(f"{where} does not break {who} up to the setting's end ({end}; worst {worst})")
        elif kind == "easier":
            clauses.append(
                f"{where} only makes the task easier for {join_words([display_name(r['agent']) for r in rows])} (worst {worst})"
            )
        else:
            clauses.append(
                f"{where} does not break {who} up to {rows[0]['levels'][-1]:g} (worst {worst}): more levels are needed"
            )
    return f"**Every factor breaks {names} within its physical range, {head}:** {join_words(clauses)}."


def breaking_values(data: BenchmarkData) -> Values:
    """The sweep's size, provenance, clean references and the breaking-point table."""
    table = sweep_table(data)
    agents = sweep_agents(data)
    factors = sorted(
        {key[1] for key in data.cells} - {"clean"},
        key=lambda f: list(FACTORS).index(f) if f in FACTORS else 99,
    )
    best_reactive, _ = best_agents(data)
    learned_best = best_learned_flow_agent(table) or f"{WINNER}@all"
    learned = [a for a in agents if "@" in a]
    return {
        **_sweep_size_values(data, factors, agents),
        "sweep_learned": join_words(
            [f"{display_name(a)} ({data.sweep_seeds[base_agent_name(a)]} seeds)" for a in learned]
        ),
        "sweep_code": _sweep_code(data, agents),
        **_clean_values(data, table),
        "unbroken_headline": _unbroken_headline(data, ["ppo_flow@all", learned_best]),
        "breaking_table": _breaking_table(
            data, factors, ["ppo_flow@all", learned_best, best_reactive["agent"]]
        ),
    }


def _sweep_size_values(data: BenchmarkData, factors: Sequence[str], agents: Sequence[str]) -> Values:
    """How many episodes, cells, factors, levels, agents and layouts the sweep has."""
    per_cell = sorted({c.episodes for key, c in data.cells.items()})
    layouts = sorted({int(r["seed"]) for r in data.sweep_rows})
    return {
        "sweep_episodes": count(len(data.sweep_rows)),
        "sweep_cells_layouts": (
            f"every agent in every cell on {per_cell[0]} test layouts"
            if len(per_cell) == 1
            else f"cells on {per_cell[0]}{VSEP}{per_cell[-1]} test layouts"
        ),
        "sweep_cell_count": str(len({key[1:] for key in data.cells})),
        "sweep_factor_count": str(len(factors)),
        "sweep_level_count": str(len({key[1:] for key in data.cells if key[1] != "clean"})),
        "sweep_agent_count": str(len(agents)),
        "sweep_layouts_per_cell": "/".join(map(str, per_cell)),
        "sweep_layouts": f"{layouts[0]:,}{VSEP}{layouts[-1]:,}",
    }


def _sweep_code(data: BenchmarkData, agents: Sequence[str]) -> str:
    """The commits the sweep's episodes were flown at, each with the agents it flew when not all of them."""
    versions = []
    for version, n, which in data.sweep_code_versions:
        note = ""
        if len(which) < len(agents):
            named = [display_name(a) for a in which]
            note = f" (only {join_words(named)})" if len(which) <= len(agents) / 2 else ""
            left = [display_name(a) for a in agents if base_agent_name(a) not in which]
            note = note or f" (all but {join_words(left)})"
        versions.append(f"{count(n)} at {commit_of(version)}{note}")
    return "; ".join(versions)


def _clean_values(data: BenchmarkData, table: Sequence[dict[str, Any]]) -> Values:
    """Each sweep agent's clean failure, on the leading table's layouts and in the sweep's own clean cell,
    best first."""
    clean = {r["agent"]: r["clean_failure"] for r in table}
    return {
        "clean_list": ", ".join(f"{display_name(a)} {rate(clean[a])}" for a in sorted(clean, key=clean.get)),
        "sweep_clean_list": ", ".join(
            f"{display_name(a)} {rate(data.cells[(a, 'clean', 0.0)].rate)}"
            for a in sorted(clean, key=clean.get)
        ),
    }


def _breaking_table(data: BenchmarkData, factors: Sequence[str], columns: Sequence[str]) -> str:
    """Where each factor breaks each agent of ``columns``, with what the factor is."""
    speed, frame_rate = neutral_level("forward_speed"), neutral_level("frame_rate")
    metres_per_frame = speed / frame_rate
    rows = []
    for factor in factors:
        label, _, what = FACTORS.get(factor, (factor, "", ""))
        if factor == "forward_speed":
            what += f" ({metres_per_frame:g} m at {speed:g} m/s)"
        rows.append([label, *(_break_cell(data, a, factor) for a in columns), what])
    header = ["factor", *(f"{display_name(a)} breaks at" for a in columns), "what it is"]
    return markdown_table(header, rows)
