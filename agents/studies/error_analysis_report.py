"""``error_analysis.md`` and its figure from a sweep's episodes: the tolerance table, the dose-response fits and
their curves (see :mod:`agents.studies.error_analysis`)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from agents.common.folders import check_writable_folder
from agents.common.tables import markdown_table, today
from agents.policies.base import LEARNED_AGENTS, base_agent_name
from agents.studies.error_analysis import (
    MIN_FULL_COURSE,
    P_VALUE_FLOOR,
    TASK_FACTORS,
    cell_quality,
    dose_curve,
    dose_features,
    fit_every_flow_agent,
    format_p,
    is_flow_agent,
    tolerance_table,
    unbroken_kind,
)
from agents.studies.weaving import turning_and_rotation_error
from flownav_env.settings_check import setting_range


def _level(value: float | None) -> str:
    return "—" if value is None else f"{value:g}"


def tolerance_lines(table: Sequence[Mapping[str, Any]]) -> list[str]:
    rows = [
        [
            r["agent"],
            r["factor"],
            r["side"],
            f"{r['clean_failure']:.2f} [{r['clean_low']:.2f}, {r['clean_high']:.2f}]",
            ", ".join(f"{x:g}" for x in r["levels"]),
            _level(r["tolerated_level"]),
            _level(r["doubling_level"]),
            f"{r['worst_failure']:.2f} at {r['worst_level']:g}" + (" (breaks)" if r["breaks"] else ""),
            r["thesis"],
        ]
        for r in table
    ]
    return [
        markdown_table(
            [
                "agent",
                "factor",
                "side",
                "clean failure [95 % CI]",
                "levels flown",
                "tolerated up to",
                "doubles at",
                "worst failure",
                "thesis",
            ],
            rows,
        )
    ]


def breaking_point_lines(table: Sequence[Mapping[str, Any]]) -> list[str]:
    """A factor × agent matrix: the first level at which each agent breaks, with its failure rate there, or
    '—' and its worst failure rate where none of the levels flown breaks it."""
    agents = sorted({r["agent"] for r in table})
    by_key = {(r["factor"], r["side"], r["agent"]): r for r in table}
    keys = sorted({(r["factor"], r["side"]) for r in table})

    def cell(row: Mapping[str, Any] | None) -> str:
        if row is None:
            return ""
        if row["breaking_level"] is None:
            return f"— ({row['worst_failure']:.2f} at {row['worst_level']:g})"
        delta = row["breaking_failure"] - row["clean_failure"]
        return f"**{row['breaking_level']:g}** ({row['breaking_failure']:.2f}, {delta:+.2f})"

    clean = {
        r["agent"]: f"{r['clean_failure']:.2f} [{r['clean_low']:.2f}, {r['clean_high']:.2f}], "
        f"{r['clean_episodes']} episodes" + (" (sweep)" if "sweep" in r["clean_source"] else "")
        for r in table
    }
    rows = [["clean failure", "", *(clean[agent] for agent in agents)]]
    rows += [
        [factor, side, *(cell(by_key.get((factor, side, agent))) for agent in agents)]
        for factor, side in keys
    ]
    return [markdown_table(["factor", "side", *agents], rows)]


def best_learned_flow_agent(table: Sequence[Mapping[str, Any]]) -> str | None:
    """The learned agent on flow depths with the lowest clean failure rate (the sweep's agents only)."""
    clean = {
        r["agent"]: r["clean_failure"]
        for r in table
        if base_agent_name(r["agent"]) in LEARNED_AGENTS and is_flow_agent({"agent": r["agent"]})
    }
    return min(clean, key=lambda agent: (clean[agent], agent)) if clean else None


def unbroken_reason(row: Mapping[str, Any]) -> str:
    """Why a factor's levels flown did not break an agent (:func:`~agents.studies.error_analysis.unbroken_kind`)."""
    worst = f"worst {row['worst_failure']:.2f} at {row['worst_level']:g}"
    kind = unbroken_kind(row)
    if kind == "end":
        allowed = setting_range(row["factor"])
        return f"flown to the end of the setting's range {allowed.interval}: nothing within it breaks the agent ({worst})"
    if kind == "easier":
        return f"this direction makes the task easier: no level fails more than clean ({worst})"
    return (
        f"not broken up to {row['levels'][-1]:g} ({worst}), short of the range's end: more levels are needed"
    )


def unbroken_lines(table: Sequence[Mapping[str, Any]]) -> list[str]:
    """The factors (and sides) that do not break the best learned flow agent, each with why."""
    agent = best_learned_flow_agent(table)
    if agent is None:
        return []
    rows = [r for r in table if r["agent"] == agent and r["breaking_level"] is None]
    lines = [
        f"### What does not break `{agent}`, the best learned flow agent, and why",
        "",
        f"Its clean failure: {next(r for r in table if r['agent'] == agent)['clean_failure']:.2f}.",
        "",
    ]
    if not rows:
        return [*lines, "Every factor flown breaks it on both sides flown.", ""]
    lines += [f"- `{r['factor']}` ({r['side']}): {unbroken_reason(r)}." for r in rows]
    return [*lines, ""]


def turning_lines(table: Sequence[Mapping[str, Any]]) -> list[str]:
    """The weaving of each agent beside its median depth error at each relative rotation error level."""
    if not table:
        return []
    levels = sorted({level for row in table for level in row["depth_error"]})
    rows = [
        [
            row["agent"],
            f"{100 * row['weaving']:.1f} %",
            *(
                "" if level not in row["depth_error"] else f"{row['depth_error'][level]:.2f}"
                for level in levels
            ),
        ]
        for row in table
    ]
    header = [
        "agent",
        "weaving, clean (path / progress − 1)",
        *(f"depth error at {level:g}" for level in levels),
    ]
    return [
        "## Relative rotation error and how much each agent turns",
        "",
        "`rotation_error` scales the told rotation of each frame, so its harm grows with how much the agent "
        "turns. Weaving: the median over clean episodes of path length over forward progress, minus 1; depth "
        "error: the median over episodes of each episode's median relative depth error (0: clean).",
        "",
        markdown_table(header, rows),
        "",
    ]


def regression_lines(fits: Mapping[str, Mapping[str, Any]]) -> list[str]:
    rows = []
    for agent, fit in fits.items():
        for name in ("const", *fit["features"]):
            low, high = fit["conf_int"][name]
            rows.append(
                [
                    agent,
                    fit["episodes"],
                    fit["layouts"],
                    name,
                    f"{fit['params'][name]:+.3f}",
                    f"{fit['bse'][name]:.3f}",
                    f"[{low:+.3f}, {high:+.3f}]",
                    format_p(fit["pvalues"][name]),
                ]
            )
    tests = [
        [agent, f"{fit['wald_statistic']:.1f}", fit["wald_df"], format_p(fit["wald_pvalue"])]
        for agent, fit in fits.items()
    ]
    return [
        markdown_table(
            [
                "agent",
                "episodes",
                "layouts (clusters)",
                "term",
                "coefficient",
                "SE (by layout)",
                "95 % CI",
                "p",
            ],
            rows,
        ),
        "",
        "Do the sensor factors act only through depth quality? Cluster-robust Wald test of adding one indicator "
        "per sensor factor to the model above (a small p: they change failures beyond what the measured depth "
        "quality explains):",
        "",
        markdown_table(["agent", "Wald statistic", "df", "p"], tests),
    ]


def quality_lines(quality: Mapping[tuple[str, float], Mapping[str, Any]]) -> list[str]:
    """How each cell's depth quality was measured: on how many full-course flights, or on all its episodes."""
    short = sorted(f"`{f}={level:g}`" for (f, level), q in quality.items() if not q["full_course"])
    lines = [
        f"Each cell's depth quality comes from the flow agents' successful episodes in it ({len(quality) - len(short)} "
        f"of {len(quality)} cells)"
    ]
    if short:
        lines[0] += (
            f"; where fewer than {MIN_FULL_COURSE} succeeded it comes from all its episodes, shorter on "
            f"average: {', '.join(short)}"
        )
    return [lines[0] + "."]


def plot_dose_response(
    rows: Sequence[Mapping[str, Any]],
    fits: Mapping[str, Mapping[str, Any]],
    quality: Mapping[tuple[str, float], Mapping[str, Any]],
    path: Path,
) -> None:
    """A panel per flow agent: each sensor cell's observed failure rate against its depth error (dots; open
    where the cell's quality came from all its episodes), and the fitted probability against depth error alone,
    at the agent's median valid points per frame (and outlier share), with its 95 % band."""
    # matplotlib takes a second to import: only the writers that draw a figure load it.
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    agents = list(fits)
    columns = min(3, len(agents))
    rows_of_panels = -(-len(agents) // columns)
    figure, axes = plt.subplots(
        rows_of_panels, columns, figsize=(4.2 * columns, 3.6 * rows_of_panels), squeeze=False
    )
    for axis in axes.flat[len(agents) :]:
        axis.set_visible(False)
    for axis, agent in zip(axes.flat, agents, strict=False):
        features, failures, used = dose_features([r for r in rows if r["agent"] == agent], quality)
        cells: dict[tuple[str, float], list[float]] = {}
        for row, failed in zip(used, failures, strict=True):
            cells.setdefault((row["factor"], float(row["level"])), []).append(failed)
        for key, outcomes in cells.items():
            error = math.exp(quality[key]["values"][0])
            full = quality[key]["full_course"]
            axis.scatter(
                error * 100,
                np.mean(outcomes),
                s=18,
                zorder=3,
                facecolors="black" if full else "none",
                edgecolors="black",
            )
        errors = np.exp(features[:, 0])
        grid = np.geomspace(errors.min(), errors.max(), 80)
        outliers = float(np.median(features[:, 2])) if features.shape[1] > 2 else 0.0
        predicted, low, high = dose_curve(fits[agent], grid, float(np.median(features[:, 1]) * 100), outliers)
        axis.plot(grid * 100, predicted, color="tab:red", label="fit, depth error alone")
        axis.fill_between(grid * 100, low, high, color="tab:red", alpha=0.2)
        axis.set_xscale("log")
        axis.xaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda value, _: f"{value:g}"))
        axis.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        axis.set_ylim(0, 1)
        axis.set_xlabel("cell's median relative depth error (%)")
        axis.set_title(f"{agent} ({fits[agent]['episodes']} episodes)", fontsize=10)
        axis.grid(alpha=0.3)
    for row in axes:
        row[0].set_ylabel("failure probability")
    axes[0][0].legend(fontsize=8, loc="upper left")
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def write_error_analysis(
    rows: Sequence[Mapping[str, Any]], out: Path, command: str, baseline: Sequence[Mapping[str, Any]] = ()
) -> list[str]:
    """Write ``error_analysis.md`` and ``dose_response.png`` into ``out``; returns the report's lines.
    ``baseline``: the clean table's episodes, the breaking points' reference where an agent has them."""
    out = Path(out)
    check_writable_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    quality = cell_quality(rows)
    fits, errors = fit_every_flow_agent(rows, quality)
    table = tolerance_table(rows, baseline)
    lines = [
        "# How estimation errors cause failures",
        "",
        f"Generated {today()} by `{command}` from {len(rows)} episodes.",
        "",
        "## Where each factor breaks each agent",
        "",
        "The first level, scanning outward from the neutral one, whose failure rate's 95 % interval lies "
        "wholly above the clean one, with its failure rate and the difference from clean; '—' where no level "
        "flown does, with the worst failure rate and its level. Clean is the agent's 300-layout clean table "
        "(`leaderboard_episodes.csv`, pooled over training seeds), or the sweep's 100-layout clean cell where "
        "it has none ('sweep'). Intervals: over training runs and layouts for a learned agent (a two-level "
        "bootstrap), Wilson over layouts for a reactive one.",
        "",
        *breaking_point_lines(table),
        "",
        *unbroken_lines(table),
        "## Tolerance per agent and factor",
        "",
        "Scanning each factor outward from its neutral level: the largest level whose failure rate stays inside "
        "the clean cell's Wilson 95 % interval, the first level whose failure rate is at least twice the clean "
        "one and above its interval ('—': none, or twice the clean rate exceeds 1), and the worst level "
        "('breaks': its interval lies above the clean one).",
        "",
        *tolerance_lines(table),
        "",
        *turning_lines(turning_and_rotation_error(rows)),
        "## Dose-response: failure against measured depth quality",
        "",
        "Logistic regression per flow agent over the sensor factors' cells and the clean one: "
        "logit P(failure) = b0 + b1 · ln(median relative depth error) + b2 · (valid depths per frame / 100) "
        "+ b3 · (share of depths off by more than half), the last term where the episodes recorded it. The "
        "covariates are the episode's cell's, measured on full-course flights, because an episode's own means "
        "depend on its length and a failed episode is short. Standard errors are clustered by layout: the "
        f"episodes of one layout share its difficulty. p-values below {P_VALUE_FLOOR:g} print as "
        f"'< {P_VALUE_FLOOR:g}'. Task factors ({', '.join(f'`{f}`' for f in TASK_FACTORS)}) change the task "
        "itself, so they are left out: that they matter beyond depth quality is true by construction. Oracle "
        "agents are left out too (they do not see the estimate).",
        "",
        *quality_lines(quality),
        "",
    ]
    if fits:
        plot_dose_response(rows, fits, quality, out / "dose_response.png")
        lines += [*regression_lines(fits), "", "![dose-response](dose_response.png)"]
    lines += [f"- `{agent}`: no fit ({reason})." for agent, reason in errors.items()]
    (out / "error_analysis.md").write_text("\n".join(lines) + "\n")
    return lines
