"""The clean tier's history table: every agent on the same clean test layouts, learned agents over all their
training seeds (``flownav leaderboard``).

Writes, to the output folder:

- ``leaderboard_episodes.csv``: every episode (resumable; one agent name per run: ``ppo_flow@3``);
- ``training_seeds.csv``: one row per (agent, training seed) with its episodes and rates;
- ``leaderboard.md``: the table (failure and success rates with 95 % intervals: over layouts for a
  reactive agent, over runs × layouts for a learned one, at least the t-interval over its seeds:
  :func:`agents.analysis.paired.runs_interval`), the interquartile mean over runs, and the
  probability that each learned agent improves on each reactive one (:mod:`agents.analysis.over_seeds`);
- ``leaderboard.png``: failure rates with their intervals, a dot per training seed.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

import flownav_env  # noqa: F401  (sets MUJOCO_GL before the machine summary queries GL)
from agents.analysis.episode_record import EpisodeRow
from agents.analysis.over_seeds import (
    LAYOUT_BLOCK,
    block_scores,
    episode_outcomes,
    interval_estimates,
    probability_of_improvement,
    run_rates,
    success_outcomes,
)
from agents.analysis.paired import (
    RUNS_INTERVAL,
    Comparison,
    compare,
    provisional_note,
    runs_interval,
    verdict,
)
from agents.analysis.records import read_records
from agents.analysis.statistics import wilson_interval
from agents.common.agent_table import AGENTS, Kind, agents_where
from agents.common.folders import check_writable_folder
from agents.common.locations import POLICIES_DIR
from agents.common.machine import code_version
from agents.common.seeds import SUITE_SEED_START, TEST_SEED_START
from agents.common.tables import markdown_table, today, write_csv
from agents.evaluation.episode_tasks import EpisodeTask, rows_of
from agents.evaluation.provenance import machine_summary
from agents.evaluation.runner import execute
from agents.policies import is_learned, policy_file, shipped_seed_runs

MIN_EPISODES = 300


def _is(agent: str, kind: Kind, *, privileged: bool | None = None) -> bool:
    """Whether ``agent`` is exactly the name of a declared agent of ``kind`` (a training seed's run name is
    none), privileged or not (either when None): read from the table when asked, so that an agent declared with
    :func:`~agents.common.agent_table.register_agent` is ranked as the shipped ones are."""
    entry = AGENTS.get(agent)
    return entry is not None and entry.kind == kind and privileged in (None, entry.privileged)


def leaderboard_runs(agents: Sequence[str], policies_dir: Path = POLICIES_DIR) -> dict[str, list[str]]:
    """Each agent's runs: a reactive agent is its own single run; a learned one is every shipped training
    seed (``ppo_flow@0``, ...). A learned agent without any is left out, with a message.

    Raises:
        ValueError: an unknown agent name.
    """
    runs: dict[str, list[str]] = {}
    for agent in agents:
        if _is(agent, "rule"):
            runs[agent] = [agent]
        elif _is(agent, "learned"):
            names = shipped_seed_runs(agent, policies_dir)
            if not names:
                print(
                    f"leaving out {agent}: no {Path(policies_dir) / agent}/seed_<k>.zip (flownav train --seeds)"
                )
                continue
            runs[agent] = names
        else:
            raise ValueError(
                f"agent must be one of {', '.join(agents_where(kind='rule') + agents_where(kind='learned'))}, "
                f"got {agent!r}"
            )
    return runs


def leaderboard_tasks(
    runs: dict[str, list[str]], episodes: int, policies_dir: Path = POLICIES_DIR
) -> list[EpisodeTask]:
    """Every run on the clean test layouts ``TEST_SEED_START ..``, layout by layout (so an interrupted
    flight leaves every agent with about the same layouts)."""
    names = [name for names in runs.values() for name in names]
    return [
        EpisodeTask(
            name,
            "clean",
            0.0,
            seed,
            policy=str(policy_file(name, directory=policies_dir)) if is_learned(name) else None,
        )
        for seed in range(TEST_SEED_START, TEST_SEED_START + episodes)
        for name in names
    ]


def summarise_runs(
    rows: Sequence[EpisodeRow], runs: dict[str, list[str]], layouts: list[int], block: int = LAYOUT_BLOCK
) -> list[dict]:
    """Per agent: runs, episodes, mean rates over runs with their 95 % intervals, and the IQM of the success
    rate over runs × layout blocks with its stratified-bootstrap interval."""
    outcomes = {agent: success_outcomes(rows, names, layouts) for agent, names in runs.items()}
    estimates = interval_estimates({agent: block_scores(o, block) for agent, o in outcomes.items()})
    table = []
    layout_set = set(layouts)
    for agent, names in runs.items():
        mine = [row for row in rows if row["agent"] in names and int(row["seed"]) in layout_set]
        n = outcomes[agent].size
        success = float(outcomes[agent].mean())
        if len(names) == 1:
            low, high = wilson_interval(int(outcomes[agent].sum()), n)
            interval = "layouts (Wilson)"
        else:
            low, high = runs_interval(outcomes[agent])
            interval = RUNS_INTERVAL
        table.append(
            {
                "agent": agent,
                "runs": len(names),
                "episodes": n,
                "success_rate": success,
                "success_low": low,
                "success_high": high,
                "failure_rate": 1.0 - success,
                "failure_low": 1.0 - high,
                "failure_high": 1.0 - low,
                "collision_rate": float(np.mean([bool(r["collision"]) for r in mine])),
                "out_of_bounds_rate": float(np.mean([bool(r["out_of_bounds"]) for r in mine])),
                "iqm_failure": 1.0 - estimates[agent]["iqm"],
                "iqm_failure_low": 1.0 - estimates[agent]["iqm_high"],
                "iqm_failure_high": 1.0 - estimates[agent]["iqm_low"],
                "interval_over": interval,
            }
        )
    return table


def improvements(
    rows: Sequence[EpisodeRow], runs: dict[str, list[str]], layouts: list[int], block: int = LAYOUT_BLOCK
) -> list[dict[str, Any]]:
    """P(learned run beats reactive agent) for every learned × reactive pair (straight left out), with its
    stratified-bootstrap interval."""
    learned = [agent for agent in runs if _is(agent, "learned")]
    reactive = [agent for agent in runs if _is(agent, "rule") and agent != "straight"]
    scores = {
        agent: block_scores(success_outcomes(rows, runs[agent], layouts), block)
        for agent in learned + reactive
    }
    result = []
    for x in learned:
        for y in reactive:
            point, low, high = probability_of_improvement(scores[x], scores[y])
            result.append({"learned": x, "reactive": y, "probability": point, "low": low, "high": high})
    return result


def plot_leaderboard(table: list[dict], seed_rows: list[dict], path: Path) -> None:
    """Failure rate per agent with its 95 % interval, and a dot per training seed of a learned agent."""
    import matplotlib  # heavy: only a command that draws the figure pays for it

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # only once the backend is chosen

    labels = [f"{r['agent']} ({r['runs']} run{'s' * (r['runs'] > 1)})" for r in table]
    # The axis keeps ~5.5 in for its title and x label whatever the longest agent name takes beside it.
    label_inches = 0.075 * max((len(label) for label in labels), default=0)
    figure, axis = plt.subplots(figsize=(max(7.5, 5.5 + label_inches), 0.55 * len(table) + 1.4))
    for y, row in enumerate(table):
        colour = "tab:blue" if _is(row["agent"], "learned") else "tab:gray"
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


def _rate(row: dict, name: str) -> str:
    return (
        f"{row[name]:.2f} [{row[name.replace('rate', 'low')]:.2f}, {row[name.replace('rate', 'high')]:.2f}]"
    )


def report_lines(
    table: list[dict],
    gains: list[dict],
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


def against_best_reactive(
    table: list[dict], rows: Sequence[EpisodeRow], runs: dict[str, list[str]], layouts: list[int]
) -> list[Comparison]:
    """Each learned agent but the privileged ones against the reactive agent (``straight`` aside) with the
    lowest failure rate, paired by layout (:func:`agents.analysis.paired.compare`)."""
    reactive = [r for r in table if _is(r["agent"], "rule") and r["agent"] != "straight"]
    learned = [r["agent"] for r in table if _is(r["agent"], "learned", privileged=False)]
    if not reactive or not learned:
        return []
    best = min(reactive, key=lambda r: r["failure_rate"])["agent"]
    failures = {a: episode_outcomes(rows, runs[a], layouts, "failure") for a in (best, *learned)}
    return [compare(a, failures[a], best, failures[best]) for a in learned]


def run_leaderboard(
    agents: Sequence[str],
    out: Path,
    *,
    episodes: int = MIN_EPISODES,
    workers: int = 2,
    policies_dir: Path = POLICIES_DIR,
    report_only: bool = False,
    command: str = "flownav leaderboard",
    block: int = LAYOUT_BLOCK,
) -> list[str]:
    """Fly (unless ``report_only``) and report the leaderboard into ``out``; returns the report's lines.

    Raises:
        ValueError: ``episodes`` below one block of layouts, ``workers`` below 1, an unknown agent, an
            unwritable ``out``, or a report with runs that have not flown every layout.
    """
    if episodes < block:  # checked before flying: the intervals over runs need whole blocks of layouts
        raise ValueError(
            f"--layouts must be >= {block} (one block of layouts for the intervals over runs), got {episodes}"
        )
    if workers < 1:
        raise ValueError(f"--workers must be >= 1, got {workers}")
    runs = leaderboard_runs(agents, policies_dir)
    out = Path(out)
    check_writable_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    csv_path = out / "leaderboard_episodes.csv"
    tasks = leaderboard_tasks(runs, episodes, policies_dir)
    if not report_only:
        execute(tasks, csv_path, workers=workers, description="leaderboard")
    rows = rows_of(tasks, read_records(csv_path)) if csv_path.is_file() else []
    layouts = list(range(TEST_SEED_START, TEST_SEED_START + episodes))
    table = summarise_runs(rows, runs, layouts, block)
    seed_rows = run_rates(rows)
    write_csv(
        out / "training_seeds.csv",
        [{k: (round(v, 4) if isinstance(v, float) else v) for k, v in r.items()} for r in seed_rows],
    )
    gains = improvements(rows, runs, layouts, block)
    plot_leaderboard(table, seed_rows, out / "leaderboard.png")
    lines = report_lines(
        table, gains, layouts, command, block, against_best_reactive(table, rows, runs, layouts)
    )
    (out / "leaderboard.md").write_text("\n".join(lines) + "\n")
    return lines
