"""The benchmark's sweep: every agent under each sensor error at several levels, on the same held-out seeds.

Each (agent, factor, level) cell flies the same seeds, so agents and levels are compared on identical
obstacle layouts. Episodes are appended to ``<out>/sweep_episodes.csv`` as they end (re-running resumes);
the summary goes to ``<out>/sweep.csv`` (collision and success rates with Wilson 95 % intervals) and the
figure ``<out>/collision_vs_error.png`` (a panel per factor, a line per agent, CI bands).

After a policy is retrained, ``--refly AGENT[,AGENT]`` deletes that agent's episodes so they are flown again;
``--compare-with OLD/sweep_episodes.csv`` adds a table to ``sweep.md`` setting each cell beside an earlier sweep.

Backends: a local process pool (default) or Ray (``--backend ray [--address ADDR]``), the same tasks either way.
"""

from __future__ import annotations

import argparse
import csv
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from agents.config import check_env_kwargs, field_range, load_config
from agents.evaluation import EVAL_SEED_START

HELP = "sweep agents × sensor errors (collision rates with 95 %% CIs; resumable; local or Ray)"


@dataclass
class SweepConfig:
    """A sweep. ``factors`` maps each FlowNavEnv sensor kwarg to its levels beyond the clean setting."""

    agents: list[str]
    factors: dict[str, list[float]]
    env_id: str = "FlowNav-v0"
    env: dict[str, Any] = field(default_factory=dict)
    episodes: int = field_range(1, 100_000, default=100)
    seed_block: int = field_range(1, 100_000, default=25)
    seed_start: int = field_range(EVAL_SEED_START, None, default=EVAL_SEED_START)
    workers: int = field_range(1, 256, default=2)
    backend: Literal["local", "ray"] = "local"
    policy_dir: str = "results/policies"

    def validate(self) -> None:
        from agents.episodes import SWEEP_FACTORS
        from agents.policies import AGENT_NAMES

        for agent in self.agents:
            if agent not in AGENT_NAMES:
                raise ValueError(f"key 'agents': unknown agent {agent!r} (allowed: {', '.join(AGENT_NAMES)})")
        for factor, levels in self.factors.items():
            if factor not in SWEEP_FACTORS:
                raise ValueError(
                    f"key 'factors.{factor}': not a sweep factor (allowed: {', '.join(SWEEP_FACTORS)})"
                )
            if (
                not isinstance(levels, list)
                or not levels
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in levels)
            ):
                raise ValueError(
                    f"key 'factors.{factor}' must be a non-empty list of numbers, got {levels!r}"
                )


def build_tasks(config: SweepConfig, agents: list[str]) -> list:
    """Every (agent, factor, level, seed) episode, in passes of ``config.seed_block`` seeds.

    Each pass flies its seeds in every cell (the clean setting first, then the factors in config order) and,
    within a cell, for every agent. A sweep cut short therefore has every cell at nearly the same count and
    has compared all agents on the same layouts; a ``seed_block`` of at least ``episodes`` flies the cells one
    after the other instead. Within a cell an agent's seeds run in a row, so a worker keeps its env.
    """
    from agents.episodes import EpisodeTask
    from agents.policies import LEARNED_AGENTS, policy_file

    seeds = range(config.seed_start, config.seed_start + config.episodes)
    passes = [seeds[start : start + config.seed_block] for start in range(0, len(seeds), config.seed_block)]
    cells: list[tuple[str, float, dict[str, Any]]] = [("clean", 0.0, dict(config.env))]
    for factor, levels in config.factors.items():
        cells += [(factor, float(level), {**config.env, factor: level}) for level in levels]
    return [
        EpisodeTask(
            agent,
            factor,
            level,
            seed,
            config.env_id,
            tuple(sorted(kwargs.items())),
            str(policy_file(agent, directory=config.policy_dir)) if agent in LEARNED_AGENTS else None,
        )
        for seed_pass in passes
        for factor, level, kwargs in cells
        for agent in agents
        for seed in seed_pass
    ]


SUMMARY_FIELDS = [
    "agent",
    "factor",
    "level",
    "episodes",
    "collisions",
    "collision_rate",
    "ci_low",
    "ci_high",
    "success_rate",
    "success_ci_low",
    "success_ci_high",
    "median_progress_m",
    "median_min_clearance_m",
]


def write_summary(rows: list[dict[str, Any]], path: Path) -> list[dict[str, Any]]:
    from agents.evaluation import summarise

    table = summarise(rows)
    with path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=SUMMARY_FIELDS)
        writer.writeheader()
        for row in table:
            writer.writerow({k: (round(v, 4) if isinstance(v, float) else v) for k, v in row.items()})
    return table


def plot_collision_vs_error(table: list[dict[str, Any]], factors: list[str], path: Path) -> None:
    """A panel per factor: collision rate against level, a line per agent, its Wilson 95 % band shaded.
    The clean setting is drawn at each factor's neutral level; a sweep of no factors gets a bar per agent."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    neutral = {
        "rotation_error": 0.0,
        "translation_error": 0.0,
        "attitude_jitter_deg": 0.0,
        "brightness": 1.0,
        "forward_speed": 1.0,
    }
    units = {
        "rotation_error": "rotation error (relative)",
        "translation_error": "translation error (relative)",
        "attitude_jitter_deg": "attitude jitter (deg)",
        "brightness": "brightness (1 = daylight)",
        "forward_speed": "forward speed (m/s; ×0.1 = m per frame)",
    }
    agents = sorted({r["agent"] for r in table})
    if not factors:  # a clean-only sweep: one bar per agent
        clean = [r for r in table if r["factor"] == "clean"]
        fig, ax = plt.subplots(figsize=(1.0 + 1.2 * len(clean), 3.4))
        rates = [r["collision_rate"] for r in clean]
        errors = [
            [r["collision_rate"] - r["ci_low"] for r in clean],
            [r["ci_high"] - r["collision_rate"] for r in clean],
        ]
        ax.bar([r["agent"] for r in clean], rates, yerr=errors, capsize=4, color="tab:blue", alpha=0.7)
        ax.set_ylim(0, 1)
        ax.set_ylabel("collision rate (95 % CI)")
        ax.set_title("clean sensors", fontsize=9)
        ax.grid(alpha=0.3, axis="y")
        fig.tight_layout()
        fig.savefig(path, dpi=120)
        plt.close(fig)
        return
    fig, axes = plt.subplots(1, len(factors), figsize=(3.6 * len(factors), 3.4), sharey=True, squeeze=False)
    for ax, factor in zip(axes[0], factors, strict=True):
        for agent in agents:
            points = [
                (neutral.get(factor, 0.0), r) for r in table if r["agent"] == agent and r["factor"] == "clean"
            ]
            points += [(r["level"], r) for r in table if r["agent"] == agent and r["factor"] == factor]
            points.sort(key=lambda p: p[0])
            if not points:
                continue
            xs = [p[0] for p in points]
            line = ax.plot(xs, [p[1]["collision_rate"] for p in points], marker="o", label=agent)[0]
            ax.fill_between(
                xs,
                [p[1]["ci_low"] for p in points],
                [p[1]["ci_high"] for p in points],
                color=line.get_color(),
                alpha=0.15,
            )
        ax.set_xlabel(units.get(factor, factor))
        ax.set_ylim(0, 1)
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("collision rate (95 % CI)")
    axes[0][-1].legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def pivot_markdown(table: list[dict[str, Any]], factor: str) -> str:
    """Collision rate [95 % CI] per agent (rows) and level (columns) of one factor, the clean run first."""
    agents = sorted({r["agent"] for r in table})
    levels = sorted({r["level"] for r in table if r["factor"] == factor})
    cells = {(r["agent"], r["factor"], r["level"]): r for r in table}
    header = "| agent | clean | " + " | ".join(f"{factor}={level:g}" for level in levels) + " |"
    lines = [header, "|---" * (len(levels) + 2) + "|"]
    for agent in agents:
        row = [cells.get((agent, "clean", 0.0))] + [cells.get((agent, factor, level)) for level in levels]
        lines.append(
            f"| {agent} | "
            + " | ".join(
                "–" if r is None else f"{r['collision_rate']:.2f} [{r['ci_low']:.2f}, {r['ci_high']:.2f}]"
                for r in row
            )
            + " |"
        )
    return "\n".join(lines)


def comparison_markdown(rows: list[dict[str, Any]], baseline_rows: list[dict[str, Any]]) -> str:
    """Collision rate per cell (rows) and agent (columns), beside the same cell of a baseline sweep, and per
    agent the share of the seeds flown in both whose episode ended the same way (collision or not): rates can
    agree while single episodes differ, e.g. on another renderer."""
    from agents.evaluation import summarise

    table, baseline = summarise(rows), summarise(baseline_rows)
    agents = sorted({r["agent"] for r in table})
    cells = {(r["agent"], r["factor"], r["level"]): r for r in table}
    before = {(r["agent"], r["factor"], r["level"]): r for r in baseline}
    outcomes: dict[tuple[str, str, float], dict[int, bool]] = {}
    for row in baseline_rows:
        outcomes.setdefault((row["agent"], row["factor"], float(row["level"])), {})[row["seed"]] = row[
            "collision"
        ]
    agreement: dict[tuple[str, str, float], list[bool]] = {}
    for row in rows:
        key = (row["agent"], row["factor"], float(row["level"]))
        if row["seed"] in outcomes.get(key, {}):
            agreement.setdefault(key, []).append(outcomes[key][row["seed"]] == row["collision"])
    keys = sorted({(r["factor"], r["level"]) for r in table}, key=lambda k: (k[0] != "clean", k))
    names = " / ".join(agents)
    header = (
        f"| factor | level | episodes | {' | '.join(agents)} | baseline: {names} | same outcome: {names} |"
    )
    lines = [header, "|---" * (len(agents) + 5) + "|"]

    def rate(row: dict[str, Any] | None) -> str:
        return "–" if row is None else f"{row['collision_rate']:.2f}"

    def share(same: list[bool] | None) -> str:
        return "–" if not same else f"{sum(same)}/{len(same)}"

    for factor, level in keys:
        counts = sorted(
            {cells[(a, factor, level)]["episodes"] for a in agents if (a, factor, level) in cells}
        )
        episodes = str(counts[0]) if len(counts) == 1 else f"{counts[0]}–{counts[-1]}"
        lines.append(
            f"| {factor} | {'–' if factor == 'clean' else f'{level:g}'} | {episodes} | "
            + " | ".join(rate(cells.get((a, factor, level))) for a in agents)
            + " | "
            + " / ".join(rate(before.get((a, factor, level))) for a in agents)
            + " | "
            + " / ".join(share(agreement.get((a, factor, level))) for a in agents)
            + " |"
        )
    return "\n".join(lines)


def write_report(
    path: Path,
    table: list[dict[str, Any]],
    config_path: Path,
    command: str,
    minutes: float | None,
    factors: list[str],
    comparison: tuple[Path, str] | None = None,
) -> None:
    """``sweep.md``: how the sweep was run and its tables (interpretation belongs in benchmark.md);
    ``comparison`` is an earlier sweep's episodes CSV and :func:`comparison_markdown` against it."""
    from agents.evaluation import format_summary
    from agents.machine import code_version, machine_summary
    from flownav_env.env import ENV_ESTIMATOR_DEFAULTS

    parts = [
        "# Sweep: collision rate per agent and sensor error",
        "",
        f"Command: `{command}`  ",
        f"Config: `{config_path}`  ",
        f"Env estimator defaults (under the config's `estimator_kwargs`): `{ENV_ESTIMATOR_DEFAULTS}`  ",
        f"Code when this report was written: {code_version()}  ",
        *(
            [
                f"Hardware: {machine_summary()}  ",
                f"Wall time of the last invocation: {minutes:.1f} min (episodes already in the CSV are not re-flown).",
            ]
            if minutes is not None
            else [
                "Rebuilt with `--report-only` from the episodes flown so far, on (the episodes may have been "
                f"flown elsewhere): {machine_summary()}"
            ]
        ),
        "",
        "```yaml",
        config_path.read_text().strip(),
        "```",
        "",
        "Collision rate with its Wilson 95 % interval, per factor (levels beyond the clean setting):",
        "",
    ]
    for factor in factors:
        parts += [f"### {factor}", "", pivot_markdown(table, factor), ""]
    if comparison is not None:
        baseline_path, comparison_table = comparison
        parts += [
            f"## Against `{baseline_path}`",
            "",
            "Collision rate per cell beside the same cell there (– where it has none), and per agent how many of",
            "the seeds flown in both ended the same way (collision or not).",
            "",
            comparison_table,
            "",
        ]
    parts += ["## All cells", "", format_summary(table), ""]
    path.write_text("\n".join(parts))


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", default="configs/sweep.yaml")
    parser.add_argument(
        "--out", default="results", help="folder of sweep_episodes.csv, sweep.csv and the figure"
    )
    parser.add_argument("--episodes", type=int, help="override the config's episodes per cell")
    parser.add_argument("--workers", type=int, help="override the config's local worker count")
    parser.add_argument("--backend", choices=("local", "ray"), help="override the config's backend")
    parser.add_argument("--address", help="Ray cluster address (default: start a local Ray instance)")
    parser.add_argument(
        "--report-only",
        action="store_true",
        help="fly nothing: rebuild sweep.csv, sweep.md and the figure from the episodes flown so far",
    )
    parser.add_argument(
        "--refly",
        metavar="AGENTS",
        help="comma-separated agents whose episodes are deleted from sweep_episodes.csv before flying, "
        "so they are flown again (after retraining a policy)",
    )
    parser.add_argument(
        "--compare-with",
        metavar="EPISODES_CSV",
        help="an earlier sweep's sweep_episodes.csv: sweep.md gets a table of each cell beside it",
    )


def run(args: argparse.Namespace) -> int:
    from agents.episodes import execute
    from agents.evaluation import drop_agents, format_summary, read_records

    config_path = Path(args.config)
    config = load_config(config_path, SweepConfig)
    for name in ("episodes", "workers", "backend"):
        if getattr(args, name) is not None:
            setattr(config, name, getattr(args, name))
    if config.episodes < 1 or config.workers < 1:
        raise ValueError(f"--episodes and --workers must be >= 1, got {config.episodes} and {config.workers}")
    check_env_kwargs(config.env, str(config_path))
    from agents.policies import LEARNED_AGENTS, policy_file

    files = {a: policy_file(a, directory=config.policy_dir) for a in config.agents if a in LEARNED_AGENTS}
    missing = {a: path for a, path in files.items() if not path.exists()}
    agents = [a for a in config.agents if a not in missing]
    for skipped, path in sorted(missing.items()):
        print(f"skipping {skipped}: no policy at {path}")
    refly = [a.strip() for a in (args.refly or "").split(",") if a.strip()]
    for agent in refly:
        if agent not in config.agents:
            raise ValueError(
                f"--refly: {agent!r} is not an agent of {config_path} ({', '.join(config.agents)})"
            )
    baseline_path = Path(args.compare_with) if args.compare_with else None
    if baseline_path is not None and not baseline_path.is_file():
        raise FileNotFoundError(f"--compare-with: no episodes CSV at {baseline_path}")
    if refly and args.report_only:
        raise ValueError(
            "--refly deletes episodes to fly them again; it cannot be combined with --report-only"
        )
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    episodes_csv = out / "sweep_episodes.csv"
    if refly:
        print(f"--refly: deleted {drop_agents(episodes_csv, refly)} episodes of {', '.join(refly)}")
    started = time.perf_counter()
    tasks = build_tasks(config, agents)
    flown = 0
    if not args.report_only:
        flown = execute(
            tasks,
            episodes_csv,
            backend=config.backend,
            workers=config.workers,
            address=args.address,
            description="sweep",
        )
    wanted = {(t.agent, t.factor, t.level, t.seed) for t in tasks}
    rows = [
        r for r in read_records(episodes_csv) if (r["agent"], r["factor"], r["level"], r["seed"]) in wanted
    ]
    table = write_summary(rows, out / "sweep.csv")
    plot_collision_vs_error(table, list(config.factors), out / "collision_vs_error.png")
    minutes = (time.perf_counter() - started) / 60
    options = {
        k: v
        for k, v in vars(args).items()
        if v not in (None, False) and k not in ("handler", "command", "report_only")
    }
    command = "flownav sweep " + " ".join(f"--{k.replace('_', '-')} {v}" for k, v in options.items())
    write_report(
        out / "sweep.md",
        table,
        config_path,
        command,
        None if args.report_only else minutes,
        list(config.factors),
        None
        if baseline_path is None
        else (baseline_path, comparison_markdown(rows, read_records(baseline_path))),
    )
    print(format_summary(table))
    print(f"{flown} episodes flown in {minutes:.1f} min; {len(rows)} in the summary")
    return 0
