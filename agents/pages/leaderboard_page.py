"""The leaderboard's page (``leaderboard.md``, ``leaderboard.png``): the clean tier's history table, the
probabilities of improvement and the gap the strongest reactive agent leaves to learning, from what
:func:`agents.evaluation.leaderboard.run_leaderboard` scored."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

from agents.analysis.over_seeds import LAYOUT_BLOCK, RunRates
from agents.analysis.paired import Comparison, provisional_note, verdict
from agents.common.machine import code_version
from agents.common.seeds import SUITE_SEED_START
from agents.common.tables import markdown_table, today
from agents.evaluation.leaderboard import Improvement, Leaderboard, LeaderboardRow, declared_as
from agents.evaluation.provenance import machine_summary


def write_leaderboard_page(board: Leaderboard, command: str) -> list[str]:
    """``leaderboard.png`` and ``leaderboard.md`` in the leaderboard's folder; returns the page's lines."""
    plot_leaderboard(board.table, board.seed_rows, board.folder / "leaderboard.png")
    lines = report_lines(board.table, board.gains, board.layouts, command, board.block, board.against_best)
    (board.folder / "leaderboard.md").write_text("\n".join(lines) + "\n")
    return lines


def plot_leaderboard(table: Sequence[LeaderboardRow], seed_rows: Sequence[RunRates], path: Path) -> None:
    """Failure rate per agent with its 95 % interval, and a dot per training seed of a learned agent."""
    import matplotlib  # heavy: only a command that draws the figure pays for it

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # only once the backend is chosen

    labels = [f"{r['agent']} ({r['runs']} run{'s' * (r['runs'] > 1)})" for r in table]
    # The axis keeps ~5.5 in for its title and x label whatever the longest agent name takes beside it.
    label_inches = 0.075 * max((len(label) for label in labels), default=0)
    figure, axis = plt.subplots(figsize=(max(7.5, 5.5 + label_inches), 0.55 * len(table) + 1.4))
    for y, row in enumerate(table):
        colour = "tab:blue" if declared_as(row["agent"], "learned") else "tab:gray"
        axis.errorbar(
            row["failure_rate"],
            y,
            xerr=[[row["failure_rate"] - row["failure_low"]], [row["failure_high"] - row["failure_rate"]]],
            fmt="o",
            color=colour,
            capsize=4,
        )
        seeds = [r["failure_rate"] for r in seed_rows if r["agent"] == row["agent"] and r["train_seed"] != ""]
        axis.scatter(seeds, [y + 0.22] * len(seeds), marker="|", s=120, color=colour, alpha=0.8)
    axis.set_yticks(range(len(table)), labels)
    axis.invert_yaxis()
    axis.set_xlim(0, 1)
    axis.set_xlabel("failure rate on the clean test layouts (collision, out of bounds or time limit)")
    axis.set_title("Agents on the same test layouts: 95 % intervals; ticks = training seeds", fontsize=10)
    axis.grid(axis="x", alpha=0.3)
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def _rate(row: Mapping[str, object], name: str) -> str:
    return (
        f"{row[name]:.2f} [{row[name.replace('rate', 'low')]:.2f}, {row[name.replace('rate', 'high')]:.2f}]"
    )


def report_lines(
    table: Sequence[LeaderboardRow],
    gains: Sequence[Improvement],
    layouts: list[int],
    command: str,
    block: int = LAYOUT_BLOCK,
    against_best: Sequence[Comparison] = (),
) -> list[str]:
    """``leaderboard.md``: set-up, the history table, the probabilities of improvement and the gap the
    strongest reactive agent leaves to learning (``against_best``: :func:`against_best_reactive`)."""
    rows = [
        [
            r["agent"],
            r["runs"],
            r["episodes"],
            _rate(r, "failure_rate"),
            _rate(r, "success_rate"),
            f"{r['collision_rate']:.2f}",
            f"{r['out_of_bounds_rate']:.2f}",
            f"{r['iqm_failure']:.2f} [{r['iqm_failure_low']:.2f}, {r['iqm_failure_high']:.2f}]",
            r["interval_over"],
        ]
        for r in table
    ]
    lines = [
        "# Leaderboard: the clean tier's history, every agent on the same clean test layouts",
        "",
        f"Generated {today()} by `{command}` (code: {code_version()}), on {len(layouts)} test layouts "
        f"(seeds {layouts[0]:,}–{layouts[-1]:,}). {machine_summary()}",
        "",
        "The leading table is the suite's, `suite.md` (`flownav suite`): every agent on every tier's frozen test "
        f"layouts, seeds from {SUITE_SEED_START:,}. Those are other layouts than these, so its clean tier's rates "
        "differ from this table's; this one is kept as the clean tier's history.",
        "",
        "A learned agent is every training seed shipped in `results/policies/<agent>/seed_<k>.zip`, each flying "
        "every layout; its rates are means over runs, and its 95 % interval is the wider of a two-level bootstrap "
        "(runs, and layouts once for all runs, since every run flew the same layouts) and a t-interval over its "
        "seeds' own rates, so it is never narrower than the spread between training runs allows (the rule of "
        "`suite.md`). A reactive agent is deterministic: one run, Wilson interval over "
        "layouts. A failure is any episode that does not reach the goal (collision, out of bounds, time limit). "
        f"IQM: interquartile mean of the failure rate over runs × blocks of {block} layouts, with "
        "rliable's stratified-bootstrap interval over runs.",
        "",
        markdown_table(
            [
                "agent",
                "runs",
                "episodes",
                "failure rate [95 % CI]",
                "success rate [95 % CI]",
                "collision",
                "out of bounds",
                "IQM failure [95 % CI]",
                "interval over",
            ],
            rows,
        ),
        "",
        "![failure rates](leaderboard.png)",
    ]
    if gains:
        lines += [
            "",
            "## Probability of improvement",
            "",
            "P(X > Y): the chance that a training run of the learned agent X has a higher success rate than the "
            f"reactive agent Y on a random block of {block} test layouts (ties count half), with "
            "rliable's stratified-bootstrap 95 % interval over runs. Above 0.5 with the interval clear of it: X "
            "reliably improves on Y.",
            "",
            markdown_table(
                ["learned X", "reactive Y", "P(X > Y) [95 % CI]"],
                [
                    [g["learned"], g["reactive"], f"{g['probability']:.2f} [{g['low']:.2f}, {g['high']:.2f}]"]
                    for g in gains
                ],
            ),
        ]
    if against_best:
        best = against_best[0].reference
        lines += ["", "## What the strongest reactive agent leaves to learning", ""]
        lines += [
            f"- `{c.agent}` − `{best}` = {c.difference:+.3f} [{c.low:+.3f}, {c.high:+.3f}], paired by layout: "
            f"{verdict(c)}{provisional_note(c)}."
            for c in against_best
        ]
        lines.append(
            f"- `{best}` is the reactive agent with the lowest failure rate here; privileged agents (they read "
            "what the sensor does not give) are references and not set against it."
        )
    return lines
