"""``benchmark.md``, the README's results block and the thesis discussion's closed-loop paragraph, written from the
committed data alone (nothing is flown).

:func:`report_values` computes one dictionary of numbers, tables, comparisons and lists of names from
:func:`~agents.studies.benchmark_data.load_benchmark_data`; the templates in ``agents/pages/templates/``
(``benchmark.md.j2``, ``readme_results.md.j2``, ``thesis_closed_loop.md.j2``, their phrases in ``wording.j2``)
word it, each verdict
from a value (a paired comparison, a list of the agents a claim holds for). The README and the thesis discussion
are hand-written files with one generated block each, between two marker lines; only that block is rewritten.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from agents.analysis.episode_record import is_flow_agent
from agents.common.folders import check_writable_folder
from agents.common.jinja_reports import rate
from agents.common.locations import CONFIGS_DIR, REPO_ROOT
from agents.common.seeds import (
    ABLATION_SEED_START,
    SUITE_SEED_STARTS,
    TEST_SEED_START,
    VALIDATION_SEED_START,
)
from agents.common.study_choices import choices
from agents.common.tables import markdown_table, today
from agents.pages.wording import display_name, join_words, render_report, span
from agents.policies.base import LEARNED_AGENTS, REACTIVE_AGENTS
from agents.reports.benchmark_sweep import sweep_values
from agents.studies.benchmark_data import BenchmarkData, commit_of, load_benchmark_data
from flownav_env.settings import EnvSettings
from flownav_env.tiers import TIER_NAMES, tier

README_MARKERS = ("<!-- results:start -->", "<!-- results:end -->")
THESIS_MARKERS = ("<!-- closed-loop:start -->", "<!-- closed-loop:end -->")
Values = dict[str, Any]


def _interval(point: float, low: float, high: float) -> str:
    return f"{point:.2f} [{low:.2f}, {high:.2f}]"


def _board(data: BenchmarkData) -> list[dict[str, Any]]:
    """The leading table's rows (``templates/benchmark_tables.j2`` words them), each with what the agent is,
    whether it is reactive, and bold for the best reactive and learned agent."""
    bold = {row["agent"] for row in data.best_agents()}
    described = choices().descriptions
    return [
        {**r, "what": described.get(r["agent"], r["agent"])}
        | {"bold": r["agent"] in bold, "reactive": r["agent"] in REACTIVE_AGENTS}
        for r in data.leaderboard
    ]


def _code_groups(data: BenchmarkData) -> list[tuple[str, str]]:
    """The commits the leaderboard was flown at, each with the agents flown there: ``(commits, agents)``."""
    groups: dict[tuple[str, ...], list[str]] = {}
    for agent, versions in data.code_versions.items():
        groups.setdefault(tuple(commit_of(v) for v in versions), []).append(f"`{agent}`")
    return [(join_words(commits), join_words(agents)) for commits, agents in groups.items()]


def _seed_ranges(data: BenchmarkData) -> list[tuple[str, list[float], dict[str, Any]]]:
    """Each learned agent's training seeds: their failure rates and the worst seed's row."""
    learned = [r["agent"] for r in data.leaderboard if r["agent"] in LEARNED_AGENTS]
    seeds = {agent: [r for r in data.seed_rows if r["agent"] == agent] for agent in learned}
    return [
        (a, [r["failure_rate"] for r in s], max(s, key=lambda r: r["failure_rate"])) for a, s in seeds.items()
    ]


def _comparisons(data: BenchmarkData, best: tuple[str, str]) -> Values:
    """The paired comparisons the reports word, by name: ``best`` (the best learned agent against the best
    reactive one) and fixed pairs; a pair with an agent missing from the leaderboard is left out."""
    c = choices()
    pairs = {
        "best": best,
        "flow_vs_ttc": ("ppo_flow", "bee_ttc"),
        "winner_vs_ttc": (c.winner, "bee_ttc"),
        "flow_vs_oracle": ("ppo_flow", "ppo_oracle"),
        "flow_vs_bee": ("ppo_flow", "bee"),
        "flow_vs_vfh": ("ppo_flow", "vfh"),
        "flow_vs_robust_rule": ("ppo_flow", "bee_robust"),
        "robust_vs_flow": ("ppo_robust", "ppo_flow"),
        "winner_vs_truth": (c.winner, c.truth_recipe),
    }
    flown = {r["agent"] for r in data.leaderboard}
    return {name: data.compare(a, b) for name, (a, b) in pairs.items() if {a, b} <= flown}


def leaderboard_values(data: BenchmarkData) -> Values:
    """The leading table, its provenance, the training seeds' spread, and the comparisons of two agents (each a
    paired test, :meth:`BenchmarkData.compare`) the reports word."""
    c = choices()
    best_reactive, best_learned = data.best_agents()
    rows = {r["agent"]: r for r in data.leaderboard}
    flow, ttc, winner = (rows[a]["failure_rate"] for a in ("ppo_flow", "bee_ttc", c.winner))
    return {
        "c": c,
        "rows": rows,
        "layouts": data.layouts,
        "leaderboard_episodes": data.leaderboard_episodes,
        "leaderboard_complete": all(r["episodes"] == r["runs"] * len(data.layouts) for r in data.leaderboard),
        "leaderboard_code": _code_groups(data),
        "board": _board(data),
        "block": data.block,
        "seed_ranges": _seed_ranges(data),
        "best_learned": best_learned["agent"],
        "best_reactive": best_reactive["agent"],
        "truth_recipe_flown": c.truth_recipe in rows,
        **_comparisons(data, (best_learned["agent"], best_reactive["agent"])),
        "winner_closes": (flow - winner) / (flow - ttc),
        "oracle_reactive": data.oracle_reactive,
        "suite_top": data.suite_top,
        "suite_complete": _suite_complete(data.suite_top),
    }


def _suite_complete(top_groups: list[dict[str, object]]) -> bool:
    """Whether every agent of the suite has flown every tier in full."""
    return len(top_groups) == len(TIER_NAMES) and all(tier["complete"] for tier in top_groups)


def _validation_order(data: BenchmarkData) -> list[str]:
    """The agents flown clean and in both validation conditions, learned ones first, then the reactive ones."""
    clean, density, speed = (data.validation[k] for k in ("clean", "density", "speed"))
    names = [n for n in clean if n in density and n in speed]
    return [n for n in names if n not in REACTIVE_AGENTS] + [n for n in names if n in REACTIVE_AGENTS]


def _validation_row(data: BenchmarkData, name: str, within: bool) -> list[str]:
    """One agent's validation row: its clean failure, each condition's with its rise, whether both stay within."""
    clean = data.validation["clean"][name]
    reactive = name in REACTIVE_AGENTS
    return [
        f"`{name}` (reactive)" if reactive else f"`{name}`",
        "–" if reactive else str(clean.runs),
        _interval(clean.rate, clean.low, clean.high),
        *(
            f"{_interval(r.rate, r.low, r.high)} ({r.rate - clean.rate:+.2f})"
            for r in (data.validation["density"][name], data.validation["speed"][name])
        ),
        "yes" if within else "no",
    ]


def _layouts_per_run(data: BenchmarkData) -> dict[str, set[int]]:
    """Each validation condition's layouts per training run (one value where every agent flew alike)."""
    return {k: {r.episodes // r.runs for r in data.validation[k].values()} for k in data.validation}


def validation_values(data: BenchmarkData) -> Values:
    """The flow-gap levers and the reactive references on validation layouts: clean, at the robustness density
    and speed, each with its difference from clean and whether both rises stay within the limit."""
    c = choices()
    clean, density, speed = (data.validation[k] for k in ("clean", "density", "speed"))
    names = _validation_order(data)
    within = [n for n in names if max(density[n].rate, speed[n].rate) - clean[n].rate <= c.max_rise]
    rows = [_validation_row(data, name, name in within) for name in names]
    header = ["config or agent", "seeds", "clean failure [95 % CI]", f"density {c.robustness_density:g} (Δ)"]
    header += [f"{c.robustness_speed:g} m/s (Δ)", f"within +{c.max_rise:.2f} at both"]
    per_run = _layouts_per_run(data)
    stage1, stage2 = data.training[c.winner].init_config or {}, data.training[c.winner].config
    return {
        "validation_table": markdown_table(header, rows),
        "validation_within": [f"`{n}`" for n in within],
        "validation_clean_layouts": sorted(per_run["clean"]),
        "validation_condition_layouts": sorted(per_run["density"] | per_run["speed"]),
        "validation_ok": {n: n in within for n in names},
        "stage2_steps": stage2["total_timesteps"],
        "stage2_lr": stage2["ppo"]["learning_rate"],
        "stage1_lr": stage1.get("ppo", {}).get("learning_rate", float("nan")),
    }


def _test_rises(data: BenchmarkData) -> dict[str, list[float]]:
    """Each agent's failure rise over its clean test failure (of the training runs the sweep flew) at the
    robustness speed, then density; an agent the sweep did not fly at both is left out."""
    c = choices()
    rise = {}
    for row in data.leaderboard:
        try:
            cells = [data.cell(row["agent"], "forward_speed", c.robustness_speed)]
            cells.append(data.cell(row["agent"], "obstacle_density", c.robustness_density))
            clean = data.sweep_clean[data.sweep_name(row["agent"])].rate
        except KeyError:
            continue
        rise[row["agent"]] = [cell.rate - clean for cell in cells]
    return rise


def _first_target_met(data: BenchmarkData) -> list[dict[str, Any]]:
    """The flow agents (neither ``straight`` nor the oracle) within the first target's failure limit."""
    c = choices()
    limit = min(c.max_failure, c.oracle_factor * data.row("ppo_oracle")["failure_rate"])
    others = ("straight", "ppo_oracle")
    return [
        r
        for r in data.leaderboard
        if is_flow_agent(r) and r["agent"] not in others and r["failure_rate"] <= limit
    ]


def target_values(data: BenchmarkData) -> Values:
    """The flow-gap targets on test layouts: who meets the first target's failure limit, each sweep agent's rise
    at the robustness speed and density over its clean failure, and the winner's training time."""
    c = choices()
    rise = _test_rises(data)
    first = _first_target_met(data)
    test_ok = {a: max(rises) <= c.max_rise for a, rises in rise.items()}
    robust = [a for a, ok in test_ok.items() if ok]
    minutes = data.training[c.winner].minutes
    in_time = max(minutes) <= c.budget_minutes
    met = {
        "the first target's failure limit": data.row(c.winner) in first,
        "the robustness limit": c.winner in robust,
        f"the time limit of {c.budget_minutes:g} min per seed, its slowest seed taking {max(minutes):.0f}": in_time,
    }
    return {
        "first_target_met": [f"{display_name(r['agent'])} ({rate(r['failure_rate'])})" for r in first],
        "rise": rise,
        "rise_members": [display_name(a) for a in rise],
        "robust_agents": [display_name(a) for a in robust],
        "winner_minutes": span(minutes),
        "winner_cores": "/".join(map(str, data.training[c.winner].cores)),
        "winner_in_time": in_time,
        "targets_met": all(met.values()),
        "winner_missed": [target for target, ok in met.items() if not ok],
        "test_ok": test_ok,
    }


def setup_values(data: BenchmarkData) -> Values:
    """The task's and training's settings: the env's defaults, the seed ranges, the shipped policies' configs."""
    c = choices()
    learned = [a for a in data.training if a != c.winner]
    seeds = {
        a: [int(r["train_seed"]) for r in data.seed_rows if r["agent"] == a] for a in [*learned, c.winner]
    }
    return {
        "env": {f.name: f.default for f in dataclasses.fields(EnvSettings)},
        "seed_starts": (VALIDATION_SEED_START, TEST_SEED_START, ABLATION_SEED_START),
        "suite_starts": SUITE_SEED_STARTS,
        # The history table's task: suite v1's clean tier.
        "env_id": tier("clean", "1").env_id,
        "ppo": data.training["ppo_flow"].config,
        "ppo_minutes": span([m for a in learned for m in data.training[a].minutes]),
        "ppo_cores": "/".join(map(str, sorted({n for a in learned for n in data.training[a].cores}))),
        "stage1": data.training[c.winner].init_config or {},
        "stage2": data.training[c.winner].config,
        "train_seeds": seeds,
        "train_configs": {agent: _training_config(agent) for agent in seeds},
    }


def _training_config(agent: str) -> str:
    """The training config of a shipped learned agent as the repository holds it: ``configs/<agent>.yaml``, or
    under ``configs/experiments/`` for a recipe of the lever search.

    Raises:
        FileNotFoundError: neither exists.
    """
    for folder in (CONFIGS_DIR, CONFIGS_DIR / "experiments"):
        if (folder / f"{agent}.yaml").exists():
            return (folder / f"{agent}.yaml").relative_to(REPO_ROOT).as_posix()
    raise FileNotFoundError(f"no training config for {agent!r} in configs/ or configs/experiments/")


def report_values(data: BenchmarkData) -> Values:
    """Every value of the three templates, computed from ``data`` (each template takes the ones it names)."""
    values = {
        **leaderboard_values(data),
        **validation_values(data),
        **target_values(data),
        **setup_values(data),
        **sweep_values(data),
    }
    shared = set(values["validation_ok"]) & set(values["test_ok"])
    values["validation_agrees"] = all(values["validation_ok"][a] == values["test_ok"][a] for a in shared)
    return values


def write_benchmark(results_dir: Path, out: Path, command: str) -> list[str]:
    """Write ``out/benchmark.md`` from the committed data under ``results_dir`` (a folder with the layout of
    ``results/``); returns its lines.

    Raises:
        FileNotFoundError: a missing input, named in one line.
        ValueError: an unwritable ``out``, or data the report cannot be worded from.
    """
    data = load_benchmark_data(Path(results_dir))
    text = render_report("benchmark.md.j2", {**report_values(data), "generated": today(), "command": command})
    out = Path(out)
    check_writable_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "benchmark.md").write_text(text)
    return text.splitlines()


def replace_block(text: str, markers: tuple[str, str], block: str, name: str = "the file") -> str:
    """``text`` with the lines between its two marker lines replaced by ``block``; the marker lines and every
    line outside them are kept as they are.

    Raises:
        ValueError: a marker missing, repeated, or the end before the start.
    """
    lines = text.split("\n")
    found = [[i for i, line in enumerate(lines) if line.strip() == marker] for marker in markers]
    for marker, where in zip(markers, found, strict=True):
        if len(where) != 1:
            raise ValueError(f"{name} must hold the line {marker!r} exactly once, found {len(where)}")
    start, end = found[0][0], found[1][0]
    if end < start:
        raise ValueError(f"{name}: {markers[1]!r} comes before {markers[0]!r}")
    return "\n".join([*lines[: start + 1], *block.rstrip("\n").split("\n"), *lines[end:]])


def write_readme_results(results_dir: Path, readme: Path) -> str:
    """The README's results block (between :data:`README_MARKERS`) rewritten from the data under ``results_dir``
    (see :func:`write_block`)."""
    return write_block(results_dir, readme, readme=True)


def write_thesis_closed_loop(results_dir: Path, text_file: Path) -> str:
    """The thesis discussion's closed-loop paragraph (between :data:`THESIS_MARKERS`) rewritten from the data under
    ``results_dir``, in ``results/thesis/DISCUSSION.md`` or the ``README.md`` built from it (see
    :func:`write_block`)."""
    return write_block(results_dir, text_file)


def write_block(results_dir: Path, text_file: Path, readme: bool = False) -> str:
    """``text_file`` with its generated block rewritten from the data under ``results_dir``: the README's
    results (``readme``) or the thesis discussion's closed-loop paragraph; written back only where it changed.

    Raises:
        FileNotFoundError: a missing input or file.
        ValueError: the file's markers missing or repeated.
    """
    text_file = Path(text_file)
    if not text_file.is_file():
        raise FileNotFoundError(f"file not found: {text_file}")
    template, markers = (
        ("readme_results.md.j2", README_MARKERS) if readme else ("thesis_closed_loop.md.j2", THESIS_MARKERS)
    )
    text = text_file.read_text()
    block = render_report(template, report_values(load_benchmark_data(Path(results_dir))))
    new = replace_block(text, markers, block, str(text_file))
    if new != text:
        text_file.write_text(new)
    return new
