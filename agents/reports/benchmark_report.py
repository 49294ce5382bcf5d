"""``benchmark.md``, the README's results block and the thesis discussion's closed-loop paragraph, written from the
committed data alone (nothing is flown).

:func:`report_values` computes one frozen dataclass of numbers, tables, comparisons and lists of names from
:func:`~agents.studies.benchmark_data.load_benchmark_data`; the templates in ``agents/pages/templates/``
(``benchmark.md.j2``, ``readme_results.md.j2``, ``thesis_closed_loop.md.j2``, their phrases in ``wording.j2``)
word it, each verdict
from a value (a paired comparison, a list of the agents a claim holds for). The README and the thesis discussion
are hand-written files with one generated block each, between two marker lines; only that block is rewritten.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

from agents.analysis.paired import Comparison
from agents.common.folders import check_writable_folder
from agents.common.locations import CONFIGS_DIR, REPO_ROOT
from agents.common.seeds import (
    ABLATION_SEED_START,
    SUITE_SEED_STARTS,
    TEST_SEED_START,
    VALIDATION_SEED_START,
)
from agents.common.study_choices import BenchmarkChoices, choices
from agents.common.tables import today
from agents.evaluation.leaderboard import LeaderboardRow
from agents.evaluation.suite import TierTopGroup
from agents.pages.wording import join_words, render_report, span
from agents.policies.base import LEARNED_AGENTS, REACTIVE_AGENTS
from agents.reports.benchmark_sweep import SweepValues, sweep_values
from agents.reports.benchmark_targets import TargetValues, ValidationValues, target_values, validation_values
from agents.studies.benchmark_data import BenchmarkData, Rate, SeedRow, commit_of, load_benchmark_data
from flownav_env.settings import EnvSettings
from flownav_env.tiers import TIER_NAMES, tier

README_MARKERS = ("<!-- results:start -->", "<!-- results:end -->")
THESIS_MARKERS = ("<!-- closed-loop:start -->", "<!-- closed-loop:end -->")


class BoardRow(LeaderboardRow):
    """A row of the leading table as the reports word it: what the agent is, whether it is reactive, and bold
    for the best reactive and learned agent."""

    what: str
    bold: bool
    reactive: bool


def _board(data: BenchmarkData) -> list[BoardRow]:
    """The leading table's rows (``templates/benchmark_tables.j2`` words them), each with what the agent is,
    whether it is reactive, and bold for the best reactive and learned agent."""
    bold = {row["agent"] for row in data.best_agents()}
    described = choices().descriptions
    return [
        BoardRow(
            **r,
            what=described.get(r["agent"], r["agent"]),
            bold=r["agent"] in bold,
            reactive=r["agent"] in REACTIVE_AGENTS,
        )
        for r in data.leaderboard
    ]


def _code_groups(data: BenchmarkData) -> list[tuple[str, str]]:
    """The commits the leaderboard was flown at, each with the agents flown there: ``(commits, agents)``."""
    groups: dict[tuple[str, ...], list[str]] = {}
    for agent, versions in data.code_versions.items():
        groups.setdefault(tuple(commit_of(v) for v in versions), []).append(f"`{agent}`")
    return [(join_words(commits), join_words(agents)) for commits, agents in groups.items()]


def _seed_ranges(data: BenchmarkData) -> list[tuple[str, list[float], SeedRow]]:
    """Each learned agent's training seeds: their failure rates and the worst seed's row."""
    learned = [r["agent"] for r in data.leaderboard if r["agent"] in LEARNED_AGENTS]
    seeds = {agent: [r for r in data.seed_rows if r["agent"] == agent] for agent in learned}
    return [
        (a, [r["failure_rate"] for r in s], max(s, key=lambda r: r["failure_rate"])) for a, s in seeds.items()
    ]


@dataclass(frozen=True)
class Comparisons:
    """The paired comparisons the reports word (:meth:`BenchmarkData.compare`), failure(first) − failure(second):
    ``best`` the best learned agent against the best reactive one, the others fixed pairs; None where an agent of
    the pair is missing from the leaderboard."""

    best: Comparison | None
    flow_vs_ttc: Comparison | None
    winner_vs_ttc: Comparison | None
    flow_vs_oracle: Comparison | None
    flow_vs_bee: Comparison | None
    flow_vs_vfh: Comparison | None
    flow_vs_robust_rule: Comparison | None
    robust_vs_flow: Comparison | None
    winner_vs_truth: Comparison | None


def _comparisons(data: BenchmarkData, best: tuple[str, str]) -> Comparisons:
    """The paired comparisons the reports word: ``best`` (the best learned agent against the best reactive one)
    and fixed pairs; None for a pair with an agent missing from the leaderboard."""
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
    return Comparisons(
        **{name: data.compare(a, b) if {a, b} <= flown else None for name, (a, b) in pairs.items()}
    )


@dataclass(frozen=True)
class LeaderboardValues(Comparisons):
    """The leading table, its provenance, the training seeds' spread, the paired comparisons, and the suite's
    top groups (:func:`leaderboard_values`)."""

    c: BenchmarkChoices
    rows: dict[str, LeaderboardRow]
    layouts: list[int]
    leaderboard_episodes: int
    leaderboard_complete: bool
    leaderboard_code: list[tuple[str, str]]
    board: list[BoardRow]
    block: int
    seed_ranges: list[tuple[str, list[float], SeedRow]]
    best_learned: str
    best_reactive: str
    truth_recipe_flown: bool
    winner_closes: float
    oracle_reactive: dict[str, Rate]
    suite_top: list[TierTopGroup]
    suite_complete: bool


def leaderboard_values(data: BenchmarkData) -> LeaderboardValues:
    """The leading table, its provenance, the training seeds' spread, and the comparisons of two agents (each a
    paired test, :meth:`BenchmarkData.compare`) the reports word."""
    c = choices()
    best_reactive, best_learned = data.best_agents()
    rows = {r["agent"]: r for r in data.leaderboard}
    flow, ttc, winner = (rows[a]["failure_rate"] for a in ("ppo_flow", "bee_ttc", c.winner))
    return LeaderboardValues(
        c=c,
        rows=rows,
        layouts=data.layouts,
        leaderboard_episodes=data.leaderboard_episodes,
        leaderboard_complete=all(r["episodes"] == r["runs"] * len(data.layouts) for r in data.leaderboard),
        leaderboard_code=_code_groups(data),
        board=_board(data),
        block=data.block,
        seed_ranges=_seed_ranges(data),
        best_learned=best_learned["agent"],
        best_reactive=best_reactive["agent"],
        truth_recipe_flown=c.truth_recipe in rows,
        **vars(_comparisons(data, (best_learned["agent"], best_reactive["agent"]))),
        winner_closes=(flow - winner) / (flow - ttc),
        oracle_reactive=data.oracle_reactive,
        suite_top=data.suite_top,
        suite_complete=_suite_complete(data.suite_top),
    )


def _suite_complete(top_groups: list[TierTopGroup]) -> bool:
    """Whether every agent of the suite has flown every tier in full."""
    return len(top_groups) == len(TIER_NAMES) and all(tier["complete"] for tier in top_groups)


@dataclass(frozen=True)
class SetupValues:
    """The task's and training's settings (:func:`setup_values`); a training config as its YAML file reads."""

    env: dict[str, object]
    seed_starts: tuple[int, int, int]
    suite_starts: dict[str, int]
    env_id: str
    ppo: dict[str, object]
    ppo_minutes: str
    ppo_cores: str
    stage1: dict[str, object]
    stage2: dict[str, object]
    train_seeds: dict[str, list[int]]
    train_configs: dict[str, str]


def setup_values(data: BenchmarkData) -> SetupValues:
    """The task's and training's settings: the env's defaults, the seed ranges, the shipped policies' configs."""
    c = choices()
    learned = [a for a in data.training if a != c.winner]
    seeds = {
        a: [int(r["train_seed"]) for r in data.seed_rows if r["agent"] == a] for a in [*learned, c.winner]
    }
    return SetupValues(
        env={f.name: f.default for f in dataclasses.fields(EnvSettings)},
        seed_starts=(VALIDATION_SEED_START, TEST_SEED_START, ABLATION_SEED_START),
        suite_starts=SUITE_SEED_STARTS,
        # The history table's task: suite v1's clean tier.
        env_id=tier("clean", "1").env_id,
        ppo=data.training["ppo_flow"].config,
        ppo_minutes=span([m for a in learned for m in data.training[a].minutes]),
        ppo_cores="/".join(map(str, sorted({n for a in learned for n in data.training[a].cores}))),
        stage1=data.training[c.winner].init_config or {},
        stage2=data.training[c.winner].config,
        train_seeds=seeds,
        train_configs={agent: _training_config(agent) for agent in seeds},
    )


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


# The parts' fields gathered as one flat set of names, as the templates name them; each part is handed on
# whole, by its fields (``vars``: shallow, as the template is given them).
@dataclass(frozen=True)
class BenchmarkValues(SweepValues, SetupValues, TargetValues, ValidationValues, LeaderboardValues):
    """Every value of the three templates (:func:`report_values`; each template takes the ones it names), and
    whether validation and test layouts agree on which agents stay within the robustness limit."""

    validation_agrees: bool


@dataclass(frozen=True)
class BenchmarkPageValues(BenchmarkValues):
    """``benchmark.md``'s values: the benchmark's, with the date and the command that wrote the page."""

    generated: str
    command: str


def report_values(data: BenchmarkData) -> BenchmarkValues:
    """Every value of the three templates, computed from ``data`` (each template takes the ones it names)."""
    validation, target = validation_values(data), target_values(data)
    shared = set(validation.validation_ok) & set(target.test_ok)
    return BenchmarkValues(
        **vars(leaderboard_values(data)),
        **vars(validation),
        **vars(target),
        **vars(setup_values(data)),
        **vars(sweep_values(data)),
        validation_agrees=all(validation.validation_ok[a] == target.test_ok[a] for a in shared),
    )


def write_benchmark(results_dir: Path, out: Path, command: str) -> list[str]:
    """Write ``out/benchmark.md`` from the committed data under ``results_dir`` (a folder with the layout of
    ``results/``); returns its lines.

    Raises:
        FileNotFoundError: a missing input, named in one line.
        ValueError: an unwritable ``out``, or data the report cannot be worded from.
    """
    data = load_benchmark_data(Path(results_dir))
    page = BenchmarkPageValues(**vars(report_values(data)), generated=today(), command=command)
    text = render_report("benchmark.md.j2", page)
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
