"""Training configs compared over their seeds on validation layouts (``flownav ablation``): the lever search's table
of what each lever buys, decided without touching a test layout.

Each config's seeds are the runs ``runs/<name>/seed_<k>/`` of ``flownav train --config ... --seeds``, or, where
that folder is gone (a new checkout), the seed's shipped policy ``results/policies/<name>/seed_<k>.zip``; every run
flies the same validation layouts (from :data:`~agents.common.seeds.ABLATION_SEED_START`) into its own CSV,
``<out>/<name>/seed_<k>.csv`` (resumable). Per config: the failure rate over runs × layouts with a two-level
bootstrap interval, each seed's failure rate, and the learning curves of its seeds. Reactive reference agents
(``--reference bee_robust``) fly the same layouts once, into ``<out>/reference/<agent>.csv``, for a row with a
Wilson interval: a lever is worth shipping only if it beats what needs no training.

With ``--tiers T --confirm`` the same comparison flies the tier's confirmation layouts instead
(:func:`tier_layouts`): fresh validation layouts on which nothing was chosen, to confirm a recipe picked on
the recipe layouts.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from agents.analysis.episode_record import EpisodeRow
from agents.analysis.paired import compare
from agents.analysis.records import read_records
from agents.analysis.statistics import failure, runs_failure
from agents.analysis.validation_rows import AblationRow
from agents.common.folders import check_writable_folder
from agents.common.locations import POLICIES_DIR
from agents.common.seeds import (
    ABLATION_SEED_START,
    TEST_SEED_START,
    TIER_CONFIRM_SEED_STARTS,
    TIER_RECIPE_SEED_STARTS,
    validation_layouts_from,
)
from agents.common.tables import today
from agents.evaluation.episode_tasks import (
    EpisodeTask,
    record_label,
    rows_of,
    set_aside_stale_episodes,
)
from agents.evaluation.runner import execute
from agents.evaluation.trained_runs import evaluations_file, how_trained, recipe_on_tier, seed_files
from agents.pages.wording import render_report
from agents.policies.base import REACTIVE_AGENTS
from agents.training.curves import plot_grouped_learning_curves
from agents.training.outputs import RunFiles
from agents.training.train_config import TrainConfig
from flownav_env.settings_check import check_env_kwargs
from flownav_env.tiers import SUITE_VERSION, TIER_NAMES, check_suite_version
from flownav_env.tiers import tier as tier_of

# Any learned agent name loads a policy file with the env settings of the config beside it; the name only
# labels the rows, and each run has its own CSV, so one name serves every config.
RUN_LABEL = "ppo_flow"


def tier_layouts(suite_version: str, confirm: bool = False) -> range:
    """The validation layouts a tier's ``flownav ablation --tiers`` may fly in ``suite_version``: its recipe
    layouts (from :data:`~agents.common.seeds.TIER_RECIPE_SEED_STARTS`, ending where the version's confirmation
    layouts begin, so that no recipe comparison flies one), or with ``confirm`` its fresh confirmation layouts
    (from :data:`~agents.common.seeds.TIER_CONFIRM_SEED_STARTS`); either ends at the test layouts at the latest.

    Raises:
        ValueError: an unknown suite version, or ``confirm`` in a version without confirmation layouts.
    """
    version = check_suite_version(suite_version)
    confirm_start = TIER_CONFIRM_SEED_STARTS.get(version)
    if not confirm:
        return range(TIER_RECIPE_SEED_STARTS[version], confirm_start or TEST_SEED_START)
    if confirm_start is None:
        raise ValueError(
            f"--confirm: suite version {version} has no confirmation layouts (versions with them: "
            f"{', '.join(TIER_CONFIRM_SEED_STARTS)})"
        )
    return range(confirm_start, TEST_SEED_START)


def ablation_tasks(
    policy: Path | None,
    episodes: int,
    env: Mapping[str, object] | None = None,
    agent: str = RUN_LABEL,
    *,
    env_id: str = "FlowNav-v0",
    first_layout: int = ABLATION_SEED_START,
    layouts_end: int = TEST_SEED_START,
) -> list[EpisodeTask]:
    """One run's episodes on validation layouts ``first_layout ..`` (short of ``layouts_end``) of ``env_id`` (a
    tier's id flies its course and sensor): clean, or with the env settings ``env`` on top of the run's own (the
    robustness conditions, such as ``obstacle_density=0.18``). ``policy`` None: a reactive ``agent``.

    Raises:
        ValueError: so many episodes that they would reach ``layouts_end`` (by default the test layouts).
    """
    if episodes < 1 or first_layout + episodes > layouts_end:
        short_of = "" if layouts_end == TEST_SEED_START else f", short of {layouts_end:,}"
        raise ValueError(
            f"--layouts must be in [1, {layouts_end - first_layout}] (validation layouts from "
            f"{first_layout:,}{short_of}), got {episodes}"
        )
    seeds = range(first_layout, first_layout + episodes)
    env = dict(env or {})
    factor, level = record_label(env)
    settings = tuple(sorted(env.items()))
    policy_path = str(policy) if policy is not None else None
    return [
        EpisodeTask(agent, factor, level, seed, env_id=env_id, env_kwargs=settings, policy=policy_path)
        for seed in seeds
    ]


def compare_configs(
    config_paths: Sequence[Path],
    seeds: Sequence[int],
    out: Path,
    *,
    runs_dir: Path = Path("runs"),
    policies_dir: Path | None = POLICIES_DIR,
    episodes: int = 100,
    workers: int = 2,
    report_only: bool = False,
    command: str = "flownav ablation",
    reference_agents: Sequence[str] = (),
    env: Mapping[str, object] | None = None,
    tier: str | None = None,
    suite_version: str = SUITE_VERSION,
    confirm: bool = False,
    layout_start: int | None = None,
) -> list[str]:
    """Fly every (config, seed) run that exists on the validation layouts and write ``ablation.md`` and
    ``ablation_curves.png`` into ``out``; returns the report's lines. A seed is its run in ``runs_dir``, else its
    policy shipped to ``policies_dir`` (None: runs only); one that is neither is listed as missing, not flown.
    ``env``: FlowNavEnv settings every run and reference agent flies with (default: clean). Its episodes are
    labelled with the setting, so they never count with another condition's in the same CSV; ``ablation.md``
    reports the condition asked, so give each condition its own ``out`` to keep each report. ``tier``: fly the
    suite tier's env (its course and sensor, of ``suite_version``) on its validation layouts from
    ``TIER_RECIPE_SEED_STARTS[suite_version]``; a recipe for every tier (``per_tier: true``) is then read as
    that tier's runs (``<name>_<tier>``, :func:`~agents.training.train_config.for_tier`). ``confirm``: fly the
    tier's confirmation layouts instead (:func:`tier_layouts`), and say so on the page. ``layout_start``: fly the
    validation layouts from there instead (a search whose range was declared before its flights).

    Raises:
        ValueError: a bad config, episode count, worker count or env setting, a reference agent that is not
            reactive, or ``confirm`` without a tier or in a suite version without confirmation layouts.
    """
    env = _checked_options(env, tier, confirm, reference_agents)
    env_id, layouts = "FlowNav-v0", range(ABLATION_SEED_START, TEST_SEED_START)
    if tier is not None:
        env_id = tier_of(tier, suite_version).env_id
        layouts = tier_layouts(suite_version, confirm)
    if layout_start is not None:
        layouts = validation_layouts_from(layout_start)
    out = Path(out)
    check_writable_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    flights = _Flights(out, episodes, env, workers, report_only, env_id, layouts.start, layouts.stop)
    rows: list[AblationRow] = []
    missing: list[str] = []
    curves: dict[str, dict[str, Path]] = {}
    for config_path in config_paths:
        config = recipe_on_tier(Path(config_path), tier)
        if isinstance(config, str):
            missing.append(f"{config} (a recipe for every tier: compare it with --tiers)")
            continue
        row = _fly_config(config, seeds, runs_dir, policies_dir, flights, missing, curves)
        if row is not None:
            rows.append(row)
    for agent in reference_agents:
        row = _fly_reference(agent, flights, missing)
        if row is not None:
            rows.append(row)
    # Paired by layout (every row flew the same ones), each row's runs resampled on their own.
    rows[1:] = [
        replace(row, versus_first=compare("", row.failures, "", rows[0].failures)) for row in rows[1:]
    ]
    if curves:
        plot_grouped_learning_curves(
            curves, out / "ablation_curves.png", "held-out evaluation return during training, per config"
        )
    text = render_report(
        "ablation.md.j2",
        ablation_values(
            rows,
            missing,
            seeds,
            command,
            env,
            bool(curves),
            flights,
            tier,
            recipe_layouts_from=tier_layouts(suite_version).start if confirm else None,
        ),
    )
    (out / "ablation.md").write_text(text)
    return text.splitlines()


def _checked_options(
    env: Mapping[str, object] | None, tier: str | None, confirm: bool, reference_agents: Sequence[str]
) -> dict[str, object]:
    """The comparison's env settings, checked, once its options agree: ``--confirm`` only with a tier, a tier
    or ``--env`` but not both, reactive reference agents only (:func:`compare_configs`' errors)."""
    checked = check_env_kwargs(dict(env or {}), "command line", key="--env")
    if confirm and tier is None:
        raise ValueError(
            f"--confirm flies a tier's confirmation layouts: give --tiers TIER ({', '.join(TIER_NAMES)})"
        )
    if tier is not None and checked:
        raise ValueError(f"--env and --tiers {tier}: a tier fixes its own settings, so give one or the other")
    for agent in reference_agents:
        if agent not in REACTIVE_AGENTS:
            raise ValueError(
                f"reference agents must be reactive ({', '.join(REACTIVE_AGENTS)}), got {agent!r}"
            )
    return checked


@dataclass(frozen=True)
class _Flights:
    """How every run and reference agent of a comparison flies: into CSVs under ``out``, ``episodes`` each,
    in the env setting ``env``, with ``workers`` processes, or not at all with ``report_only``, on ``env_id``'s
    layouts from ``first_layout`` (short of ``layouts_end``)."""

    out: Path
    episodes: int
    env: dict[str, object]
    workers: int
    report_only: bool
    env_id: str
    first_layout: int
    layouts_end: int

    def tasks(self, policy: Path | None, agent: str = RUN_LABEL) -> list[EpisodeTask]:
        return ablation_tasks(
            policy,
            self.episodes,
            self.env,
            agent,
            env_id=self.env_id,
            first_layout=self.first_layout,
            layouts_end=self.layouts_end,
        )


def _fly_config(
    config: TrainConfig,
    seeds: Sequence[int],
    runs_dir: Path,
    policies_dir: Path | None,
    flights: _Flights,
    missing: list[str],
    curves: dict[str, dict[str, Path]],
) -> AblationRow | None:
    """Fly each finished seed of a config; its report row (None when no seed has every episode). Seeds not
    trained or not fully flown are added to ``missing``, each seed's evaluations file to ``curves``."""
    name = config.name
    outcomes, per_seed, counts = [], [], {"collision": 0, "out_of_bounds": 0}
    trained: list[tuple[int, RunFiles]] = []
    for seed in seeds:
        files = seed_files(runs_dir, policies_dir, name, seed, config.total_timesteps)
        if files is None:
            steps = RunFiles.of_seed(runs_dir, name, seed).trained_steps()
            unfinished = f" (unfinished: {steps:,} of {config.total_timesteps:,} steps)" if steps else ""
            missing.append(f"{name} seed {seed}{unfinished}")
            continue
        tasks = flights.tasks(files.policy)
        csv_path = flights.out / name / f"seed_{seed}.csv"
        flown = _fly(tasks, csv_path, flights.workers, flights.report_only, f"{name} seed {seed}")
        if len(flown) < flights.episodes:
            missing.append(f"{name} seed {seed} ({len(flown)} of {flights.episodes} episodes)")
            continue
        by_seed = {int(r["seed"]): r for r in flown}
        outcomes.append([bool(by_seed[t.seed]["success"]) for t in tasks])
        per_seed.append((seed, 1.0 - float(np.mean(outcomes[-1]))))
        counts["collision"] += sum(r["collision"] for r in flown)
        counts["out_of_bounds"] += sum(r["out_of_bounds"] for r in flown)
        evaluations = evaluations_file(files)
        if evaluations is not None:
            curves.setdefault(name, {})[f"seed {seed}"] = evaluations
        trained.append((seed, files))
    if not outcomes:
        return None
    commands, minutes = how_trained(trained)
    row = _config_row(name, np.array(outcomes, float), per_seed, counts)
    return replace(row, commands=commands, minutes_per_seed=minutes)


def _fly_reference(agent: str, flights: _Flights, missing: list[str]) -> AblationRow | None:
    """Fly a reactive reference agent; its report row, or None (and a line in ``missing``) while short of
    episodes."""
    tasks = flights.tasks(None, agent=agent)
    reference_csv = flights.out / "reference" / f"{agent}.csv"
    if not flights.report_only:
        set_aside_stale_episodes(tasks, reference_csv, f"{agent}'s parameters have changed; flying it anew")
    flown = _fly(tasks, reference_csv, flights.workers, flights.report_only, f"{agent} (reference)")
    if len(flown) < flights.episodes:
        missing.append(f"{agent} ({len(flown)} of {flights.episodes} episodes)")
        return None
    by_seed = {int(r["seed"]): r for r in flown}
    return _reference_row(agent, [by_seed[task.seed] for task in tasks])


def _config_row(
    name: str, outcomes: np.ndarray, per_seed: list[tuple[int, float]], counts: dict[str, int]
) -> AblationRow:
    """A config's row: failure over runs × layouts (its interval from two seeds on), its outcome rates and each
    seed's failure."""
    rate, low, high = runs_failure(outcomes)
    several, total = len(outcomes) > 1, outcomes.size
    return AblationRow(
        config=name,
        seeds=len(outcomes),
        episodes=total,
        failure=rate,
        failure_low=low if several else None,
        failure_high=high if several else None,
        success=float(outcomes.mean()),
        collision=counts["collision"] / total,
        out_of_bounds=counts["out_of_bounds"] / total,
        per_seed=per_seed,
        failures=1.0 - outcomes,
    )


def _fly(
    tasks: list[EpisodeTask], csv_path: Path, workers: int, report_only: bool, description: str
) -> list[EpisodeRow]:
    """Fly ``tasks`` into ``csv_path`` (resumably; nothing with ``report_only``) and return their records."""
    csv_path.parent.mkdir(parents=True, exist_ok=True)
    if not report_only:
        execute(tasks, csv_path, workers=workers, description=description)
    return rows_of(tasks, read_records(csv_path)) if csv_path.is_file() else []


def _reference_row(agent: str, flown: Sequence[EpisodeRow]) -> AblationRow:
    """A reactive reference agent's row: one run, a Wilson interval over its layouts."""
    rate, low, high, total = failure(flown)
    return AblationRow(
        config=f"{agent} (reactive, reference)",
        seeds=None,
        episodes=total,
        failure=rate,
        failure_low=low,
        failure_high=high,
        success=1 - rate,
        collision=sum(bool(row["collision"]) for row in flown) / total,
        out_of_bounds=sum(bool(row["out_of_bounds"]) for row in flown) / total,
        per_seed=None,
        failures=np.array([[0.0 if row["success"] else 1.0 for row in flown]]),
    )


@dataclass(frozen=True)
class AblationValues:
    """Every value ``ablation.md`` words; ``recipe_layouts_from``: where a confirmation's recipe layouts start."""

    generated: str
    command: str
    first_layout: int
    last_layout: int
    condition: str
    seeds: list[int]
    rows: list[AblationRow]
    missing: list[str]
    curves: bool
    recipe_layouts_from: int | None  # None: the rows flew the tier's recipe layouts, or the ablation layouts


def ablation_values(
    rows: list[AblationRow],
    missing: list[str],
    seeds: Sequence[int],
    command: str,
    env: Mapping[str, object],
    curves: bool,
    flights: _Flights,
    tier: str | None = None,
    *,
    recipe_layouts_from: int | None = None,
) -> AblationValues:
    """:class:`AblationValues` of the comparison's ``rows``, flown as ``flights`` says."""
    condition = ", ".join(f"{k}={v}" for k, v in sorted(env.items())) if env else "clean sensors"
    return AblationValues(
        generated=today(),
        command=command,
        first_layout=flights.first_layout,
        last_layout=flights.first_layout + flights.episodes - 1,
        condition=f"tier `{tier}`, {flights.env_id}" if tier else condition,
        seeds=list(seeds),
        rows=rows,
        missing=missing,
        curves=curves,
        recipe_layouts_from=recipe_layouts_from,
    )
