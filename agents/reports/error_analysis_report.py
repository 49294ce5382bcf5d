"""``error_analysis.md`` and its figure from a sweep's episodes: the tolerance table, the dose-response fits and
their curves (see :mod:`agents.studies.error_analysis`)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TypedDict

import numpy as np

from agents.analysis.dose_response import (
    MIN_FULL_COURSE,
    P_VALUE_FLOOR,
    TASK_FACTORS,
    CellQuality,
    DoseFit,
    cell_quality,
    dose_curve,
    dose_features,
    fit_every_flow_agent,
)
from agents.analysis.episode_record import EpisodeRow
from agents.analysis.records import read_records
from agents.analysis.tolerance_rows import ToleranceRow
from agents.analysis.weaving import AgentWeaving, turning_and_rotation_error
from agents.common.folders import check_writable_folder
from agents.common.locations import RESULTS_DIR
from agents.common.tables import today
from agents.evaluation.sweep import pool_every_seed
from agents.pages.wording import render_report
from agents.studies.error_analysis import (
    baseline_of_flown_runs,
    best_learned_flow_agent,
    tolerance_table,
    unbroken_kind,
)
from agents.studies.error_analysis_tiers import (
    BEST_LEARNED,
    FULL_CELL_LAYOUTS,
    PairedCell,
    SidewaysCell,
    ToleranceShift,
    cell_counts,
    paired_cells,
    rows_by_tier,
    sideways_cells,
    tier_baseline,
    tolerance_shifts,
)
from flownav_env.settings_check import setting_range
from flownav_env.tiers import SUITE_VERSION, tier_of_env_id


def _range_text(row: ToleranceRow) -> str:
    return setting_range(row["factor"]).interval if unbroken_kind(row) == "end" else ""


def plot_dose_response(
    rows: Sequence[EpisodeRow],
    fits: Mapping[str, DoseFit],
    quality: Mapping[tuple[str, float], CellQuality],
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


class FactorSide(TypedDict):
    """One factor on one side of its neutral level, with each agent's tolerance row there."""

    factor: str
    side: str
    rows: dict[str, ToleranceRow]


class UnbrokenRow(ToleranceRow):
    """A factor no level flown breaks the best agent at: why (:func:`unbroken_kind`), and the range it was flown
    to the end of ("" unless it was)."""

    kind: str
    range: str


@dataclass(frozen=True)
class SweepFindings:
    """One sweep's sections of the error report (:func:`report_values`): its tolerance table, the factors that
    never break the best learned flow agent, the weaving against rotation error and the dose-response fits."""

    episodes: int
    table: list[ToleranceRow]
    agents: list[str]
    first_rows: dict[str, ToleranceRow]
    keys: list[FactorSide]
    best: str | None
    unbroken: list[UnbrokenRow]
    turning: list[AgentWeaving]
    turning_levels: list[float]
    quality: dict[tuple[str, float], CellQuality]
    short: list[str]
    min_full_course: int
    p_floor: float
    task_factors: tuple[str, ...]
    fits: dict[str, DoseFit]
    errors: dict[str, str]


@dataclass(frozen=True)
class SweepSections(SweepFindings):
    """:class:`SweepFindings` as ``templates/error_analysis_sections.md.j2`` words them: with the dose-response
    figure's file name and what the breaking points' clean rate is."""

    figure: str
    clean_text: str


@dataclass(frozen=True)
class ErrorAnalysisValues:
    """``templates/error_analysis.md.j2``'s values: one sweep's sections, its episodes, and the page's date and
    command."""

    values: SweepSections
    episodes: int
    generated: str
    command: str


def report_values(rows: Sequence[EpisodeRow], baseline: Sequence[EpisodeRow] = ()) -> SweepFindings:
    """Every value of ``templates/error_analysis.md.j2`` from a sweep's episodes (``rows``) and the clean table's
    (``baseline``), the fits among them."""
    quality = cell_quality(rows)
    fits, errors = fit_every_flow_agent(rows, quality)
    table = tolerance_table(rows, baseline)
    keys: dict[tuple[str, str], dict[str, ToleranceRow]] = {}
    for row in table:
        keys.setdefault((row["factor"], row["side"]), {})[row["agent"]] = row
    best = best_learned_flow_agent(table)
    unbroken = [r for r in table if r["agent"] == best and r["breaking_level"] is None]
    turning = turning_and_rotation_error(rows)
    return SweepFindings(
        episodes=len(rows),
        table=table,
        agents=sorted({r["agent"] for r in table}),
        first_rows={r["agent"]: r for r in reversed(table)},
        keys=[FactorSide(factor=f, side=side, rows=keys[(f, side)]) for f, side in sorted(keys)],
        best=best,
        unbroken=[UnbrokenRow(**r, kind=unbroken_kind(r), range=_range_text(r)) for r in unbroken],
        turning=turning,
        turning_levels=sorted({level for row in turning for level in row["depth_error"]}),
        quality=quality,
        short=sorted(f"`{f}={level:g}`" for (f, level), q in quality.items() if not q["full_course"]),
        min_full_course=MIN_FULL_COURSE,
        p_floor=P_VALUE_FLOOR,
        task_factors=TASK_FACTORS,
        fits=fits,
        errors=errors,
    )


def write_error_analysis(
    rows: Sequence[EpisodeRow], out: Path, command: str, baseline: Sequence[EpisodeRow] = ()
) -> list[str]:
    """Write ``error_analysis.md`` and ``dose_response.png`` into ``out``; returns the report's lines.
    ``baseline``: the clean table's episodes, the breaking points' reference where an agent has them."""
    out = Path(out)
    check_writable_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    values = SweepSections(
        **vars(report_values(rows, baseline)),
        figure="dose_response.png",
        clean_text="the agent's 300-layout clean table (`leaderboard_episodes.csv`, pooled over training seeds)",
    )
    if values.fits:
        plot_dose_response(rows, values.fits, values.quality, out / values.figure)
    text = render_report("error_analysis.md.j2", ErrorAnalysisValues(values, len(rows), today(), command))
    (out / "error_analysis.md").write_text(text)
    return text.split("\n")[:-1]


def write_error_analysis_from(
    episodes: Sequence[Path],
    out: Path,
    command: str,
    baseline: Path | None = None,
    *,
    compare_with: tuple[Path, Path] | None = None,
) -> list[str]:
    """The error report from sweep episodes CSVs, each learned agent pooled over its seeds: on the current
    suite's tiers, :func:`write_tiered_error_analysis` (``baseline``: the suite's episodes; ``compare_with``: an
    earlier sweep's episodes and its clean table), else :func:`write_error_analysis` (``baseline``: the clean
    table of the same training runs). ``baseline`` None: each agent's clean cell in the sweep.

    Raises:
        FileNotFoundError: an episodes, baseline or comparison file missing.
        ValueError: the files hold no readable episode.
    """
    flown = []
    for path in episodes:
        if not Path(path).is_file():
            raise FileNotFoundError(f"--episodes {path}: no such file (fly a sweep first: flownav sweep)")
        flown += read_records(Path(path))
    rows = pool_every_seed(flown)
    if not rows:
        raise ValueError(f"--episodes {', '.join(map(str, episodes))} holds no readable episode")
    named: dict[str, Path | None] = {"--baseline": baseline}
    if compare_with is not None:
        named.update({"--compare-with": compare_with[0], "--compare-with's baseline": compare_with[1]})
    for name, given in named.items():
        if given is not None and not Path(given).is_file():
            raise FileNotFoundError(f"{name} {given}: no such file")
    clean = baseline_of_flown_runs(read_records(Path(baseline)), flown) if baseline else []
    if not on_current_suite(rows):
        return write_error_analysis(rows, out, command, pool_every_seed(clean))
    earlier = None
    if compare_with is not None:
        before = read_records(compare_with[0])
        earlier = (
            pool_every_seed(before),
            pool_every_seed(baseline_of_flown_runs(read_records(compare_with[1]), before)),
        )
    return write_tiered_error_analysis(rows, out, command, pool_every_seed(clean), earlier)


def default_baseline(episodes: Sequence[Path]) -> Path:
    """The clean episodes a sweep's breaking points are read against by default: the suite's on the current
    suite's tiers, else the clean table's (``results/leaderboard_episodes.csv``)."""
    rows = [row for path in episodes if Path(path).is_file() for row in read_records(Path(path))]
    return RESULTS_DIR / (
        "suite_episodes.csv" if rows and on_current_suite(rows) else "leaderboard_episodes.csv"
    )


def on_current_suite(rows: Sequence[EpisodeRow]) -> bool:
    """Whether every row flew a tier of the current suite version (a tiered report), not an older task."""
    return all(
        (found := tier_of_env_id(row["env_id"] or "")) is not None and found[0] == SUITE_VERSION
        for row in rows
    )


@dataclass(frozen=True)
class TierSections:
    """One tier's part of the tiered error report (:func:`tier_values`)."""

    tier: str
    env_id: str | None
    counts: Mapping[str, int]
    sections: SweepSections
    agents: list[str]
    paired: dict[tuple[str, float, str], PairedCell]
    cells: list[tuple[str, float]]
    sideways: list[SidewaysCell]


@dataclass(frozen=True)
class TieredErrorAnalysisValues:
    """``templates/error_analysis_tiers.md.j2``'s values: each tier's sections, and the clean tier's breaking
    points beside an earlier sweep's (``shifts``; ``moved`` those that moved)."""

    tiers: list[TierSections]
    episodes: int
    full_cell: int
    shifts: list[ToleranceShift]
    moved: list[ToleranceShift]
    best_label: str
    earlier_episodes: int
    generated: str
    command: str


def tier_values(
    tier: str, rows: Sequence[EpisodeRow], baseline: Sequence[EpisodeRow], figure: str
) -> TierSections:
    """One tier's part of the tiered report: the single sweep's sections (:func:`report_values`) with the
    figure's file name, each cell paired by layout against clean, and its successes' sideways extent."""
    paired = paired_cells(rows)
    return TierSections(
        tier=tier,
        env_id=rows[0]["env_id"],
        counts=cell_counts(rows),
        sections=SweepSections(
            **vars(report_values(rows, baseline)),
            figure=figure,
            clean_text=f"the agent's rate on the suite's {tier} tier (`suite_episodes.csv`: its 300 frozen "
            "layouts, pooled over training seeds)",
        ),
        agents=sorted({cell.agent for cell in paired}),
        paired={(cell.factor, cell.level, cell.agent): cell for cell in paired},
        cells=sorted({(cell.factor, cell.level) for cell in paired}),
        sideways=sideways_cells(rows, tier, SUITE_VERSION),
    )


def write_tiered_error_analysis(
    rows: Sequence[EpisodeRow],
    out: Path,
    command: str,
    suite_rows: Sequence[EpisodeRow],
    earlier: tuple[Sequence[EpisodeRow], Sequence[EpisodeRow]] | None = None,
) -> list[str]:
    """Write ``error_analysis.md`` and a dose-response figure per tier into ``out`` from a sweep flown on suite
    tiers (``rows``, learned agents pooled over their seeds), each tier's breaking points against the suite's
    clean rates on it (``suite_rows``); with ``earlier`` (an earlier sweep's episodes and its clean table's),
    each clean-tier tolerance beside that sweep's. Returns the report's lines."""
    out = Path(out)
    check_writable_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    tiers = []
    for tier, members in rows_by_tier(rows).items():
        figure = "dose_response.png" if tier == "clean" else f"dose_response_{tier}.png"
        values = tier_values(tier, members, tier_baseline(suite_rows, members[0]["env_id"]), figure)
        if values.sections.fits:
            plot_dose_response(members, values.sections.fits, values.sections.quality, out / figure)
        tiers.append(values)
    shifts: list[ToleranceShift] = []
    if earlier is not None and tiers:
        before = tolerance_table(*earlier)
        shifts = tolerance_shifts(tiers[0].sections.table, before)
    text = render_report(
        "error_analysis_tiers.md.j2",
        TieredErrorAnalysisValues(
            tiers=tiers,
            episodes=len(rows),
            full_cell=FULL_CELL_LAYOUTS,
            shifts=shifts,
            moved=[s for s in shifts if s.moved != "same"],
            best_label=BEST_LEARNED,
            earlier_episodes=0 if earlier is None else len(earlier[0]),
            generated=today(),
            command=command,
        ),
    )
    (out / "error_analysis.md").write_text(text)
    return text.split("\n")[:-1]
