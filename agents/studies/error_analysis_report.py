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
    dose_curve,
    dose_features,
    fit_dose_response,
    is_flow_agent,
    tolerance_table,
    turning_and_rotation_error,
)
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
        return f"**{row['breaking_level']:g}** ({row['breaking_failure']:.2f})"

    clean = {r["agent"]: f"{r['clean_failure']:.2f}" for r in table}
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
    """Why a factor's levels flown did not break an agent: the factor's range ends there, the direction makes
    the task easier, or the levels simply stop short (then more levels are needed)."""
    farthest = row["levels"][-1]
    try:
        allowed = setting_range(row["factor"])
    except ValueError:
        allowed = None
    end = None if allowed is None else (allowed.high if row["side"] == "above" else allowed.low)
    if end is not None and math.isclose(farthest, end):
        return (
            f"flown to the end of the setting's range {allowed.interval}: nothing within it breaks the agent "
            f"(worst {row['worst_failure']:.2f} at {row['worst_level']:g})"
        )
    if row["worst_failure"] <= row["clean_failure"]:
        return (
            f"this direction makes the task easier: no level fails more than clean (worst "
            f"{row['worst_failure']:.2f} at {row['worst_level']:g})"
        )
    return (
        f"not broken up to {farthest:g} (worst {row['worst_failure']:.2f} at {row['worst_level']:g}), short of "
        "the range's end: more levels are needed"
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
                    name,
                    f"{fit['params'][name]:+.3f}",
                    f"{fit['bse'][name]:.3f}",
                    f"[{low:+.3f}, {high:+.3f}]",
                    f"{fit['pvalues'][name]:.2g}",
                ]
            )
    tests = [
        [agent, f"{fit['lr_statistic']:.1f}", fit["lr_df"], f"{fit['lr_pvalue']:.2g}"]
        for agent, fit in fits.items()
    ]
    return [
        markdown_table(["agent", "episodes", "term", "coefficient", "SE", "95 % CI", "p"], rows),
        "",
        "Do the factors act only through depth quality? Likelihood-ratio test of adding one indicator per "
        "factor to the model above (a small p: the factors change failures beyond what the measured depth "
        "quality explains):",
        "",
        markdown_table(["agent", "LR statistic", "df", "p"], tests),
    ]


def plot_dose_response(
    rows: Sequence[Mapping[str, Any]], fits: Mapping[str, Mapping[str, Any]], path: Path
) -> None:
    """A panel per flow agent: observed failure rate in deciles of median depth error (dots); the fit's mean
    predicted probability over the same deciles' episodes (squares: how well all its terms together follow
    the dots); and the fitted probability against depth error alone, at the agent's median valid points per
    frame (and outlier share), with its 95 % band."""
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
        features, failures, _ = dose_features([r for r in rows if r["agent"] == agent])
        errors = np.exp(features[:, 0])
        edges = np.unique(np.quantile(errors, np.linspace(0, 1, 11)))
        which = np.clip(np.searchsorted(edges, errors, side="right") - 1, 0, len(edges) - 2)
        bins = [b for b in range(len(edges) - 1) if (which == b).any()]
        centres = np.array([np.median(errors[which == b]) for b in bins])
        observed = [failures[which == b].mean() for b in bins]
        fitted = fits[agent]["model"].predict(np.column_stack([np.ones(len(errors)), features]))
        axis.scatter(centres * 100, observed, color="black", s=18, zorder=3, label="observed (deciles)")
        axis.scatter(
            centres * 100,
            [fitted[which == b].mean() for b in bins],
            marker="s",
            facecolors="none",
            edgecolors="tab:red",
            s=24,
            zorder=3,
            label="fit, mean over the decile",
        )
        grid = np.geomspace(errors.min(), errors.max(), 80)
        outliers = float(np.median(features[:, 2])) if features.shape[1] > 2 else 0.0
        predicted, low, high = dose_curve(fits[agent], grid, float(np.median(features[:, 1]) * 100), outliers)
        axis.plot(grid * 100, predicted, color="tab:red", label="fit, depth error alone")
        axis.fill_between(grid * 100, low, high, color="tab:red", alpha=0.2)
        axis.set_xscale("log")
        axis.xaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda value, _: f"{value:g}"))
        axis.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        axis.set_ylim(0, 1)
        axis.set_xlabel("episode's median relative depth error (%)")
        axis.set_title(f"{agent} ({fits[agent]['episodes']} episodes)", fontsize=10)
        axis.grid(alpha=0.3)
    for row in axes:
        row[0].set_ylabel("failure probability")
    axes[0][0].legend(fontsize=8, loc="upper left")
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def write_error_analysis(rows: Sequence[Mapping[str, Any]], out: Path, command: str) -> list[str]:
    """Write ``error_analysis.md`` and ``dose_response.png`` into ``out``; returns the report's lines."""
    out = Path(out)
    check_writable_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    flow_agents = sorted({r["agent"] for r in rows if is_flow_agent(r)})
    fits: dict[str, Mapping[str, Any]] = {}
    skipped = []
    for agent in flow_agents:
        try:
            fits[agent] = fit_dose_response([r for r in rows if r["agent"] == agent])
        except ValueError as reason:
            skipped.append(f"- `{agent}`: no fit ({reason}).")
    table = tolerance_table(rows)
    lines = [
        "# How estimation errors cause failures",
        "",
        f"Generated {today()} by `{command}` from {len(rows)} episodes.",
        "",
        "## Where each factor breaks each agent",
        "",
        "The first level, scanning outward from the neutral one, whose failure rate's Wilson 95 % interval lies "
        "wholly above the clean cell's, with its failure rate; '—' where no level flown does, with the worst "
        "failure rate and its level.",
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
        "Logistic regression per flow agent, pooled over every factor and level: "
        "logit P(failure) = b0 + b1 · ln(median relative depth error) + b2 · (valid depths per frame / 100) "
        "+ b3 · (share of depths off by more than half), the last term where the episodes recorded it "
        "(`outlier_share`, the mean over the episode's frames). "
        "Episodes without a measured depth error are left out; oracle agents too (they do not see the estimate).",
        "",
    ]
    if fits:
        plot_dose_response(rows, fits, out / "dose_response.png")
        lines += [*regression_lines(fits), "", "![dose-response](dose_response.png)"]
    lines += skipped
    (out / "error_analysis.md").write_text("\n".join(lines) + "\n")
    return lines
