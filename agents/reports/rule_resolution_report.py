"""``results/rule_resolution/``: the page and figure of :mod:`agents.studies.rule_resolution`, written from its
episodes (``flownav rule-resolution --report-only`` rebuilds them without flying)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TypedDict, Unpack

from agents.common.folders import write_text_atomically
from agents.common.seeds import (
    RULE_RESOLUTION_CONFIRM_SEED_START,
    RULE_RESOLUTION_REFINE_SEED_START,
    RULE_RESOLUTION_SEED_START,
)
from agents.common.tables import today
from agents.pages.wording import render_report
from agents.studies.rule_resolution import (
    CANDIDATES,
    REFINE_CANDIDATES,
    REFINE_RULE,
    RESOLUTIONS,
    RULES,
    SEARCH_RESOLUTIONS,
    TIERS,
    TODAY,
    ResolutionRow,
    RuleResolutionResult,
    run_rule_resolution,
)

PAGE = "rule_resolution.md"
FIGURE = "rule_resolution.png"


@dataclass(frozen=True)
class RuleResolutionValues:
    """Every value ``templates/rule_resolution.md.j2`` words (:func:`page_values`): the study's design, each
    stage's rows, its picks and verdicts, and the figure's file name ("" where none is drawn)."""

    generated: str
    command: str
    rules: tuple[str, ...]
    tiers: tuple[str, ...]
    today: str
    candidates: list[str]
    layouts: dict[str, int]
    starts: dict[str, int]
    search_tried: int
    tried: int
    episodes: int
    search: list[ResolutionRow]
    refinement: list[ResolutionRow]
    confirmation: list[ResolutionRow]
    search_done: bool
    refinement_done: bool
    refine_rule: str
    refine_candidates: list[str]
    picks: dict[str, str | None]
    refined: str | None
    chosen: dict[str, str | None]
    confirmed: dict[str, bool | None]
    nearest: ResolutionRow | None
    missing: list[str]
    figure: str


def page_values(result: RuleResolutionResult, command: str, figure: bool) -> RuleResolutionValues:
    """Every value ``rule_resolution.md`` words (``templates/rule_resolution.md.j2``)."""
    compared = [row for row in result.rows if row.stage == "search" and row.versus_today is not None]
    # The candidate nearest to a pick: the largest drop against the rule's own (None before any comparison).
    nearest = min(
        compared, key=lambda row: row.versus_today.difference if row.versus_today else 0.0, default=None
    )

    def stage(name: str) -> list[ResolutionRow]:
        return [row for row in result.rows if row.stage == name]

    return RuleResolutionValues(
        generated=today(),
        command=command,
        rules=RULES,
        tiers=TIERS,
        today=TODAY.name,
        candidates=[resolution.name for resolution in CANDIDATES],
        layouts=result.layouts,
        starts={
            "search": RULE_RESOLUTION_SEED_START,
            "refinement": RULE_RESOLUTION_REFINE_SEED_START,
            "confirmation": RULE_RESOLUTION_CONFIRM_SEED_START,
        },
        search_tried=len(RULES) * len(SEARCH_RESOLUTIONS),
        tried=result.configurations_tried,
        episodes=sum(row.episodes for row in result.rows),
        search=stage("search"),
        refinement=stage("refinement"),
        confirmation=stage("confirmation"),
        search_done=not any(m.endswith("(search)") for m in result.missing),
        refinement_done=not any(m.endswith("(refinement)") for m in result.missing),
        refine_rule=REFINE_RULE,
        refine_candidates=[resolution.name for resolution in REFINE_CANDIDATES],
        picks=result.picks,
        refined=result.refined,
        chosen=result.chosen,
        confirmed=result.confirmed,
        nearest=nearest,
        missing=result.missing,
        figure=FIGURE if figure else "",
    )


def plot_rule_resolution(result: RuleResolutionResult, path: Path) -> bool:
    """Each candidate minus the rule's own resolution, with its 95 % interval, a panel per rule: the search
    filled (the search blue, the refinement green), the confirmation hollow. Returns whether there was anything to draw (nothing is written if not)."""
    compared = [row for row in result.rows if row.versus_today is not None]
    if not compared:
        return False
    import matplotlib  # heavy: only a command that draws the figure pays for it

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # only once the backend is chosen

    names = [resolution.name for resolution in RESOLUTIONS if resolution != TODAY]
    colours = {"search": "tab:blue", "refinement": "tab:green", "confirmation": "tab:orange"}
    offsets = {"search": -0.2, "refinement": 0.0, "confirmation": 0.2}
    figure, axes = plt.subplots(
        1, len(RULES), figsize=(3.4 * len(RULES), 2.8), sharex=True, sharey=True, squeeze=False
    )
    for axis, rule in zip(axes[0], RULES, strict=True):
        axis.axvline(0.0, color="grey", linewidth=0.8)
        for row in compared:
            if row.rule != rule or row.versus_today is None:
                continue
            y = names.index(row.resolution) + offsets[row.stage]
            d = row.versus_today
            filled = row.stage != "confirmation"
            axis.errorbar(
                d.difference,
                y,
                xerr=[[d.difference - d.low], [d.high - d.difference]],
                fmt="o",
                color=colours[row.stage],
                markerfacecolor=None if filled else "white",
                capsize=3,
                label=row.stage,
            )
        axis.set_title(rule)
        axis.set_xlabel(f"failure minus at {TODAY.name}")
    axes[0][0].set_yticks(range(len(names)), names)
    axes[0][0].invert_yaxis()
    handles, labels = [], []
    for axis in axes[0]:
        for handle, label in zip(*axis.get_legend_handles_labels(), strict=True):
            if label not in labels:
                handles.append(handle)
                labels.append(label)
    axes[0][-1].legend(handles, labels, loc="best", fontsize="small")
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)
    return True


class StudyOptions(TypedDict, total=False):
    """The options of :func:`~agents.studies.rule_resolution.run_rule_resolution` that say how it flies."""

    search_layouts: int
    refine_layouts: int
    confirm_layouts: int
    report_only: bool


def write_rule_resolution(out: Path, command: str, **options: Unpack[StudyOptions]) -> list[str]:
    """Fly what the study lacks (unless ``report_only``), then write ``rule_resolution.md`` and its figure into
    ``out``; returns the page's lines.

    Raises:
        ValueError: as :func:`~agents.studies.rule_resolution.run_rule_resolution`.
    """
    result = run_rule_resolution(Path(out), **options)
    figure = plot_rule_resolution(result, Path(out) / FIGURE)
    text = render_report("rule_resolution.md.j2", page_values(result, command, figure))
    write_text_atomically(Path(out) / PAGE, text)
    return text.splitlines()
