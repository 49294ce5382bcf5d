"""The suite's rows: their CSV (``suite.csv``, ``score.csv``), checked when read; outside rows set beside the
published ones. Their tables per tier and figure, and ``suite.md`` itself, are :mod:`agents.pages`'
(:mod:`~agents.pages.suite_tables`, :mod:`~agents.pages.suite_plot`, :mod:`~agents.pages.suite_page`).
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, TypedDict, cast

from agents.common.agent_table import published_name_like
from agents.common.folders import write_text_atomically
from agents.common.seeds import SUITE_LAYOUTS
from agents.evaluation.verification_record import verification_mark
from agents.policies.base import PRIVILEGED_AGENTS
from flownav_env.tiers import SUITE_VERSION, TIER_NAMES, check_flown_settings, tier

if TYPE_CHECKING:  # typing has it from Python 3.11; annotations are not evaluated at run time
    from typing import NotRequired

# The rates the table reports: failure (did not reach the goal), then the exclusive ways an episode ends
# (flownav_env.task.EPISODE_OUTCOMES), whose rates sum to 1.
OUTCOMES = ("failure", "collision", "out_of_bounds", "timeout", "success")
# One row per (agent, tier): the suite's CSV and flownav score's.
SUMMARY_COLUMNS = [
    "suite_version",
    "tier",
    "env_id",
    "agent",
    "runs",
    "layouts",
    "episodes",
    *(f"{outcome}_{part}" for outcome in OUTCOMES for part in ("rate", "low", "high")),
    "interval_over",
    # What the agent was flown with (its episodes' env kwargs, as JSON), so that a row set beside the
    # published table can be checked against its tier; and whether the agent is privileged (a reference).
    "env_kwargs",
    "privileged",
]


class SuiteRow(TypedDict):
    """One (agent, tier) row of the suite (:data:`SUMMARY_COLUMNS`, typed), as summarised from episodes or read
    from a suite or score CSV. ``included`` only on a row set beside the published ones: its file's
    verification mark (:func:`~agents.evaluation.verification_record.verification_mark`), or True. A test keeps
    the fields and the columns in step."""

    suite_version: str
    tier: str
    env_id: str
    agent: str
    runs: int
    layouts: int
    episodes: int
    failure_rate: float
    failure_low: float
    failure_high: float
    collision_rate: float
    collision_low: float
    collision_high: float
    out_of_bounds_rate: float
    out_of_bounds_low: float
    out_of_bounds_high: float
    timeout_rate: float
    timeout_low: float
    timeout_high: float
    success_rate: float
    success_low: float
    success_high: float
    interval_over: str
    env_kwargs: str
    privileged: bool
    included: NotRequired[str | bool]


def outcome_interval(row: SuiteRow, outcome: str) -> tuple[float, float, float]:
    """(rate, low, high) of ``outcome`` (one of :data:`OUTCOMES`) in ``row``."""
    rates = cast("Mapping[str, float]", row)  # every <outcome>_<part> column holds a float
    return rates[f"{outcome}_rate"], rates[f"{outcome}_low"], rates[f"{outcome}_high"]


# A tier leaves room to improve when its best agent still fails at least this often.
HEADROOM_FAILURE = 0.15


# flownav score's rows, one per (agent, tier): every agent scored into the folder keeps its own.
SCORE_CSV = "score.csv"

# Beside a score.csv: each agent's shown name → the run names its episode records carry (what
# flownav leaderboard --include ranks it on).
SCORE_RUNS_JSON = "score_runs.json"

# Where a suite CSV comes from, for messages about a file that is not one.
SCORE_CSV_HINT = "flownav score writes one"


def read_suite_csv(path: Path, version: str = SUITE_VERSION) -> list[SuiteRow]:
    """Rows of a suite or score CSV (:data:`SUMMARY_COLUMNS`), typed.

    Raises:
        ValueError: not such a CSV, a torn or edited row, or rows of another suite version (their tiers are
            other tasks); one line naming ``path`` (and the line, for a row).
        FileNotFoundError: no file at ``path``.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(
            f"no suite CSV at {path} ({SCORE_CSV_HINT}: <out>/score.csv, by default runs/score)"
        )
    try:
        with path.open(newline="") as handle:
            reader = csv.DictReader(handle)
            missing = [name for name in SUMMARY_COLUMNS if name not in (reader.fieldnames or [])]
            if missing:
                raise ValueError(
                    f"{path} is not a suite CSV ({SCORE_CSV_HINT}): it lacks the columns {', '.join(missing)}"
                )
            rows = [(reader.line_num, row) for row in reader]
    except (UnicodeDecodeError, csv.Error) as error:
        raise ValueError(f"{path} is not a suite CSV ({SCORE_CSV_HINT}): {error}") from None
    typed = []
    for line, row in rows:
        if None in row or None in row.values():
            fewer_or_more = "fewer" if None in row.values() else "more"
            raise ValueError(
                f"{path}, line {line}: the row has {fewer_or_more} fields than the header (torn or edited); "
                "score the agent again with flownav score"
            )
        if row["suite_version"] != version:
            raise ValueError(
                f"{path} holds rows of suite version {row['suite_version']!r}, but this is suite version "
                f"{version!r}: its tiers are other tasks; score the agent again with flownav score "
                f"--suite-version {version}, or pass --suite-version {row['suite_version']}"
            )
        try:
            tier(row["tier"], version)
        except ValueError as error:
            raise ValueError(f"{path}, line {line}: {error}") from None
        check_row_task(row, path)
        typed.append(check_row_numbers(_typed_row(row, path, line), path, line))
    return typed


# score.csv keeps rates to 4 decimals: the exclusive rates' sum may miss 1, and a rate its interval, by this.
RATE_TOLERANCE = 3e-4
# The outcomes that partition the episodes (every one but ``failure``, which is "not success").
EXCLUSIVE_OUTCOMES = tuple(outcome for outcome in OUTCOMES if outcome != "failure")


def check_row_numbers(row: SuiteRow, path: Path, line: int) -> SuiteRow:
    """``row`` (typed) if its counts and rates can be a suite row: runs >= 1, layouts a prefix of the frozen
    layouts (1 to :data:`~agents.common.seeds.SUITE_LAYOUTS`), episodes runs × layouts; every rate and bound in
    [0, 1] with low <= rate <= high; the exclusive outcomes' rates summing to 1, failure 1 - success; and
    privileged data marked: a FlowNav agent that reads it is marked privileged.

    Raises:
        ValueError: one line naming ``path``, the line, the column and its value.
    """
    where = f"{path}, line {line}"
    if row["runs"] < 1 or not 1 <= row["layouts"] <= SUITE_LAYOUTS:
        raise ValueError(
            f"{where}: runs {row['runs']} and layouts {row['layouts']}: a suite row has runs >= 1 and layouts "
            f"from 1 to {SUITE_LAYOUTS} (a prefix of the frozen layouts)"
        )
    if row["episodes"] != row["runs"] * row["layouts"]:
        raise ValueError(
            f"{where}: episodes {row['episodes']} is not runs × layouts ({row['runs']} × {row['layouts']})"
        )
    for outcome in OUTCOMES:
        rate, low, high = outcome_interval(row, outcome)
        if not all(math.isfinite(value) and 0.0 <= value <= 1.0 for value in (rate, low, high)):
            raise ValueError(
                f"{where}: {outcome} rate {rate!r} [{low!r}, {high!r}]: rates and bounds lie in [0, 1]"
            )
        if not low - RATE_TOLERANCE <= rate <= high + RATE_TOLERANCE:
            raise ValueError(
                f"{where}: {outcome} rate {rate:g} lies outside its interval [{low:g}, {high:g}]"
            )
    total = sum(outcome_interval(row, outcome)[0] for outcome in EXCLUSIVE_OUTCOMES)
    if abs(total - 1.0) > RATE_TOLERANCE:
        raise ValueError(
            f"{where}: the rates of {', '.join(EXCLUSIVE_OUTCOMES)} sum to {total:g}, not 1 (each episode ends one way)"
        )
    if abs(row["failure_rate"] - (1.0 - row["success_rate"])) > RATE_TOLERANCE:
        raise ValueError(
            f"{where}: failure rate {row['failure_rate']:g} is not 1 - success rate {row['success_rate']:g}"
        )
    if row["agent"] in PRIVILEGED_AGENTS and not row["privileged"]:
        raise ValueError(
            f"{where}: {row['agent']} reads privileged data, but its row is not marked privileged"
        )
    return row


def _typed_row(row: Mapping[str, str], path: Path, line: int) -> SuiteRow:
    """A CSV row's :data:`SUMMARY_COLUMNS` as numbers and flags where they are ones.

    Raises:
        ValueError: a count or rate that is not a number, naming ``path``, the line and the column.
    """
    typed: dict[str, object] = {}
    for name in SUMMARY_COLUMNS:
        value = row[name]
        try:
            if name.endswith(("_rate", "_low", "_high")):
                typed[name] = float(value)
            elif name in ("runs", "layouts", "episodes"):
                typed[name] = int(value)
            else:
                typed[name] = value == "True" if name == "privileged" else value
        except ValueError:
            raise ValueError(
                f"{path}, line {line}: column {name} is {value!r}, not a number; score the agent again with "
                "flownav score"
            ) from None
    return cast(SuiteRow, typed)  # every column set above, each as its type


def read_included(
    paths: Sequence[str | Path], version: str = SUITE_VERSION
) -> tuple[list[SuiteRow], list[Path]]:
    """The rows of the ``score.csv`` files ``paths`` (:func:`read_suite_csv`), each file read once however
    often or under whatever spelling it is named, and the files read, in the order first given. Each row's
    ``included`` says whether ``flownav verify`` vouches for its file (:func:`verification_mark`).

    Raises:
        ValueError: a file without rows, a row under a published agent's name (it would replace that agent's
            rows), two rows of one agent and tier, or any error of :func:`read_suite_csv`.
        FileNotFoundError: a path with no file.
    """
    files = list(dict.fromkeys(Path(path).resolve() for path in paths))
    rows: list[SuiteRow] = []
    seen: dict[tuple[str, str], Path] = {}
    for path in files:
        found = read_suite_csv(path, version)
        if not found:
            raise ValueError(f"{path} holds no rows: flownav score writes one per tier it flew whole")
        for row in found:
            if (like := published_name_like(row["agent"])) is not None:
                raise ValueError(
                    f"{path}: agent {row['agent']!r} reads as the published agent {like!r}: its rows would pass for "
                    "that agent's; score yours under another name (flownav score --name)"
                )
            key = (row["tier"], row["agent"])
            if key in seen:
                raise ValueError(
                    f"{path}: a second row of agent {row['agent']!r} on tier {row['tier']} (the first is in "
                    f"{seen[key]}): one row per agent and tier"
                )
            seen[key] = path
        mark = verification_mark(path)
        rows += [{**row, "included": mark} for row in found]
    return rows, files


def other_agents_rows(
    path: Path, agent: str, runs: Sequence[str], version: str = SUITE_VERSION
) -> list[dict[str, str]]:
    """The rows of the score CSV at ``path`` of agents other than ``agent`` (flying ``runs``), so that agents
    scored into one folder each keep their rows; ``agent``'s own are replaced by its new ones, as are those of
    the same runs under another name (``--name``). Rows of another suite version than ``version``, or of another
    shape, are dropped: they are
    other tasks, scored again with flownav score."""
    if not path.is_file():
        return []
    same = {agent} | {name for name, flown in read_score_runs(path.parent).items() if flown == list(runs)}
    with path.open(newline="") as handle:
        found = list(csv.DictReader(handle))
    return [
        {column: row[column] for column in SUMMARY_COLUMNS}
        for row in found
        if row.get("agent") not in same
        and row.get("suite_version") == version
        and None not in row.values()
        and all(column in row for column in SUMMARY_COLUMNS)
    ]


def write_score_runs(folder: Path, agent: str, runs: Sequence[str]) -> None:
    """Record that ``agent``'s rows in ``folder``'s score CSV rest on the episodes of ``runs``, beside any other
    agent scored into the folder (the same runs under an earlier name are forgotten)."""
    path = Path(folder) / SCORE_RUNS_JSON
    known = {name: flown for name, flown in read_score_runs(folder).items() if flown != list(runs)}
    known[agent] = list(runs)
    write_text_atomically(path, json.dumps(known, indent=1, sort_keys=True) + "\n")


def read_score_runs(folder: Path) -> dict[str, list[str]]:
    """``folder``'s :data:`SCORE_RUNS_JSON` (empty when there is none, or it is no such mapping)."""
    path = Path(folder) / SCORE_RUNS_JSON
    try:
        found = json.loads(path.read_text()) if path.is_file() else {}
    except (OSError, json.JSONDecodeError):
        return {}
    if not isinstance(found, dict):
        return {}
    return {str(agent): [str(run) for run in runs] for agent, runs in found.items() if isinstance(runs, list)}


def check_row_task(row: Mapping[str, object], path: Path) -> None:
    """Refuse a row whose episodes were not flown on its tier's task (:func:`flownav_env.tiers.
    check_flown_settings`): a changed course or sensor, or privileged data for an agent not declared privileged.

    Raises:
        ValueError: one line naming ``path``, the agent, the tier and the setting.
    """
    try:
        flown = json.loads(str(row["env_kwargs"] or "{}"))
        if not isinstance(flown, dict):
            raise ValueError(f"env_kwargs is not a JSON object: {row['env_kwargs']!r}")
        check_flown_settings(
            str(row["agent"]),
            flown,
            str(row["tier"]),
            privileged=str(row["privileged"]) in ("True", "true"),
            version=str(row.get("suite_version") or SUITE_VERSION),
        )
    except (ValueError, json.JSONDecodeError) as error:
        raise ValueError(f"{path}: {error}") from None


def merge_rows(published: Sequence[SuiteRow], included: Sequence[SuiteRow]) -> list[SuiteRow]:
    """The published rows and the included ones (an included row replaces a published row of the same agent
    and tier), tier by tier, best first."""
    merged = {(row["tier"], row["agent"]): row.copy() for row in published}
    for row in included:
        merged[(row["tier"], row["agent"])] = {**row, "included": row.get("included") or True}
    order = {name: index for index, name in enumerate(TIER_NAMES)}
    return sorted(merged.values(), key=lambda r: (order[r["tier"]], r["failure_rate"], r["agent"]))
