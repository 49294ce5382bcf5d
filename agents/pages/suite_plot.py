"""The suite's figure: failure rate with its 95 % interval per agent, a panel per tier, as ``suite.md`` ranks them
(privileged references grey, agents outside the top group hollow, included rows red)."""

from __future__ import annotations

import textwrap
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from agents.analysis.paired import MIN_RANKED_SEEDS
from agents.common.agent_table import kind_of
from agents.evaluation.suite_report import HEADROOM_FAILURE, SuiteRow
from flownav_env.tiers import SUITE_VERSION, TIER_NAMES

if TYPE_CHECKING:  # matplotlib is heavy: imported only where a figure is drawn
    from matplotlib.axes import Axes

# Inches per character of a tick label (10 pt) and of the title (12 pt) in matplotlib's default sans font: the
# figure is made as wide as its longest agent name needs, and the title wrapped to the width, so that one tier's
# panel (the demo's) shows whole names and a whole title, not a panel squeezed between clipped ones.
_LABEL_INCH_PER_CHAR = 0.075
_TITLE_INCH_PER_CHAR = 0.1
_PANEL_WIDTH_IN = 3.2
# A wrapped title's every further line, and the least height that holds the title, one row and the axis label.
_TITLE_LINE_IN = 0.25
_MIN_HEIGHT_IN = 2.8


def plot_suite(
    rows: Sequence[SuiteRow], path: Path, top_groups: Mapping[str, Sequence[str]] | None = None
) -> None:
    """Failure rate with its 95 % interval per agent, a panel per tier; with ``top_groups`` (tier → its top
    group, as the page ranks), a ranked agent outside its tier's top group is drawn hollow."""
    import matplotlib  # heavy: only a command that draws the figure pays for it

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # only once the backend is chosen

    tiers = [name for name in TIER_NAMES if any(r["tier"] == name for r in rows)]
    agents = figure_order(rows)
    labels = [plot_label(agent, rows) for agent in agents]
    longest = max((len(line) for label in labels for line in label.split("\n")), default=0)
    width = _PANEL_WIDTH_IN * max(len(tiers), 1) + _LABEL_INCH_PER_CHAR * longest
    title = textwrap.fill(_plot_title(rows, ranked=top_groups is not None), int(width / _TITLE_INCH_PER_CHAR))
    figure, axes = plt.subplots(
        1,
        max(len(tiers), 1),
        figsize=(width, max(0.35 * len(agents) + 1.4 + _TITLE_LINE_IN * title.count("\n"), _MIN_HEIGHT_IN)),
        sharey=True,
        squeeze=False,
    )
    for axis, name in zip(axes[0], tiers, strict=False):
        _plot_tier(axis, name, rows, agents, None if top_groups is None else top_groups.get(name, ()))
    axes[0][0].set_yticks(range(len(agents)), labels)
    axes[0][0].invert_yaxis()  # the first agent at the top, as the tables read
    for tick, agent in zip(axes[0][0].get_yticklabels(), agents, strict=True):
        if any(r.get("included") for r in rows if r["agent"] == agent):
            tick.set_color("tab:red")
    figure.suptitle(title)
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)


def figure_order(rows: Sequence[SuiteRow]) -> list[str]:
    """The figure's agents top to bottom in the order the page's tables list them: ranked agents, then
    provisional ones (learned, too few training seeds), then privileged references, each group by its mean
    failure rate over the tiers shown (the panels share one axis, so one order serves every tier)."""
    by_agent: dict[str, list[SuiteRow]] = {}
    for row in rows:
        by_agent.setdefault(row["agent"], []).append(row)

    def place(agent: str) -> tuple[int, float, str]:
        mine = by_agent[agent]
        group = (
            2
            if any(r["privileged"] for r in mine)
            else int(kind_of(agent) == "learned" and min(r["runs"] for r in mine) < MIN_RANKED_SEEDS)
        )
        return group, sum(r["failure_rate"] for r in mine) / len(mine), agent

    return sorted(by_agent, key=place)


def _plot_title(rows: Sequence[Mapping[str, object]], *, ranked: bool) -> str:
    """The figure's title: the suite version and what its marks mean (hollow ones only where ``ranked``)."""
    included = (
        " (red: included rows, on the layouts their label says)"
        if any(r.get("included") for r in rows)
        else ""
    )
    version = str(rows[0].get("suite_version") or SUITE_VERSION) if rows else SUITE_VERSION
    hollow = "; hollow: outside the tier's top group" if ranked else ""
    return (
        f"FlowNav suite v{version}: failure rate with 95 % interval (dotted: {HEADROOM_FAILURE}; grey: "
        f"privileged references, never ranked{hollow}){included}"
    )


def _plot_tier(
    axis: Axes,
    name: str,
    rows: Sequence[SuiteRow],
    agents: list[str],
    top_group: Sequence[str] | None = None,
) -> None:
    """One tier's panel: each agent's failure rate with its interval, at the agent's row of the y axis; with
    ``top_group``, a ranked (not privileged) agent outside it hollow."""
    found = {r["agent"]: r for r in rows if r["tier"] == name}
    for index, agent in enumerate(agents):
        row = found.get(agent)
        if row is None:
            continue
        rate = row["failure_rate"]
        colour = _marker_colour(row)
        outside = top_group is not None and not row.get("privileged") and agent not in top_group
        axis.errorbar(
            rate,
            index,
            xerr=[[max(rate - row["failure_low"], 0.0)], [max(row["failure_high"] - rate, 0.0)]],
            fmt="o",
            color=colour,
            markerfacecolor="white" if outside else colour,
            capsize=3,
        )
    axis.axvline(HEADROOM_FAILURE, color="grey", linestyle=":", linewidth=1)
    axis.set_xlim(0, 1)
    axis.set_title(name)
    axis.set_xlabel("failure rate")


def _marker_colour(row: Mapping[str, object]) -> str:
    """Red for an included row, grey for a privileged reference, blue for a scored agent."""
    if row.get("included"):
        return "tab:red"
    return "tab:grey" if row.get("privileged") else "tab:blue"


def plot_label(agent: str, rows: Sequence[SuiteRow]) -> str:
    """``agent`` in full on the figure's axis; an included agent marked with the layouts its rows rest on."""
    counts = sorted({r["layouts"] for r in rows if r["agent"] == agent and r.get("included")})
    if any(r.get("privileged") for r in rows if r["agent"] == agent):
        agent = f"{agent}\n(privileged reference)"
    if not counts:
        return agent
    layouts = str(counts[0]) if len(counts) == 1 else f"{counts[0]}-{counts[-1]}"
    return f"{agent}\n(included, {layouts} layout{'' if layouts == '1' else 's'})"
