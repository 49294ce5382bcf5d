"""How estimation errors cause failures (``flownav sweep --analysis``): a tolerance table per agent and factor,
and one dose-response model per agent that pools every factor and level.

- **Tolerance.** Per agent and factor, on each side of the factor's neutral level: the largest level whose
  failure rate stays inside the clean interval, the first level at which the failure rate reaches twice the
  clean one (none when twice the clean rate would exceed 1), and the first level whose interval lies wholly
  above the clean one (it breaks). The clean rate is the 300-layout clean table's where the agent has one.
  Intervals are over training runs and layouts for a learned agent pooled over its seeds, Wilson otherwise.
- **Dose-response.** Episode failure against its cell's depth quality (:func:`cell_quality`: median relative
  depth error, valid depths per frame and, where recorded, the share of depths off by more than half, measured
  on the cell's full-course flights so that no episode's covariate depends on its own length), pooled over the
  sensor factors' cells and the clean one, fitted as a logistic regression (statsmodels) with standard errors
  clustered by layout. A second fit adds one indicator per sensor factor; a cluster-robust Wald test of those
  indicators says whether the factors act on failures through more than the measured depth quality (e.g. the
  drone's motion, or what the estimator cannot measure). Task factors (:data:`TASK_FACTORS`) change the task
  itself and are left out of both. p-values are printed no smaller than :data:`P_VALUE_FLOOR`.

Agents on oracle observations are left out of the dose-response: their observation is not the estimate.
"""

from __future__ import annotations

import dataclasses
import json
import math
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from scipy import stats

from agents.evaluation.statistics import failure_interval
from agents.policies.base import LEARNED_AGENTS, base_agent_name
from flownav_env.settings import EnvSettings
from flownav_env.settings_check import setting_range

# What the thesis concluded for each factor it varied (../shared/thesis-figures.md), for the tolerance table.
THESIS_VERDICTS = {
    "attitude_jitter_deg": "excessively inaccurate from 1.5°; acceptable at 0.5°",
    "forward_speed": "accurate at 0.05–0.15 m per frame; fewer matches beyond, little data below 0.02",
    "brightness": "accuracy falls from the 4th of six light levels",
    "rotation_error": "at 8 % the depths no longer give accurate information: a strong threat",
    "translation_error": "a band close to a direct 2–10 % variation",
}
NOT_TESTED = "not tested"
# Depth quality per episode: log median relative error, valid depths per frame (in hundreds), and the share of
# depths off by more than half, where the episodes recorded it (not in files from before it existed).
DOSE_FEATURES = ("log_depth_error", "valid_points_per_100", "outlier_share")
# Factors that change the task itself (how fast, how cluttered, how visible), not what the drone is told or
# estimates: "they matter beyond depth quality" would be true of them by construction, so the dose-response
# fits and their test use the sensor factors only.
TASK_FACTORS = ("forward_speed", "obstacle_density", "brightness")
# A cell's quality is measured on its successful (full-course) episodes when it has at least this many.
MIN_FULL_COURSE = 5
P_VALUE_FLOOR = 1e-6


def neutral_level(factor: str) -> float:
    """The level at which ``factor`` does nothing: its env default (1 for brightness, the default speed...)."""
    fields = dataclasses.fields(EnvSettings)
    defaults = {item.name: item.default for item in fields if isinstance(item.default, int | float)}
    if factor not in defaults:
        raise ValueError(f"{factor!r} is not an env setting, so it has no neutral level")
    return float(defaults[factor])


def failure(rows: Sequence[Mapping[str, Any]]) -> tuple[float, float, float, int]:
    """Failure rate, its 95 % interval (over training runs too where the rows pool several:
    :func:`~agents.evaluation.statistics.failure_interval`) and the episodes."""
    n = len(rows)
    failures = sum(not bool(r["success"]) for r in rows)
    low, high = failure_interval(rows)
    return failures / n, low, high, n


BASELINE_SOURCE = "the 300-layout clean table"
SWEEP_CLEAN_SOURCE = "the sweep's clean cell"


def tolerance_table(
    rows: Sequence[Mapping[str, Any]], baseline: Sequence[Mapping[str, Any]] = ()
) -> list[dict[str, Any]]:
    """Per agent, factor and side of the neutral level: the clean failure rate [CI], the largest level still
    inside the clean interval, the first level at which the failure rate doubles, the first level at which it
    breaks (its interval lies wholly above the clean one), and the thesis's verdict.

    The clean rate is the agent's episodes in ``baseline`` (the leaderboard's clean layouts, pooled over
    training seeds like ``rows``) where it has any, else the sweep's own clean cell: a breaking point measured
    against a noisy 100-layout clean cell moves with that cell's luck.

    A level is tolerated while its failure rate stays at or below the clean interval's upper end (a level
    that fails less than clean is no harm); scanning outward from the neutral level, the tolerated level is
    the last one before the first level above it.
    """
    cells: dict[tuple[str, str, float], list[Mapping[str, Any]]] = {}
    for row in rows:
        cells.setdefault((row["agent"], row["factor"], float(row["level"])), []).append(row)
    clean_rows = _clean_rows(cells, baseline)
    table = []
    for agent in sorted({key[0] for key in cells}):
        if agent not in clean_rows:
            continue
        clean, clean_low, clean_high, clean_episodes = failure(clean_rows[agent][0])
        clean_fields = {
            "clean_failure": clean,
            "clean_low": clean_low,
            "clean_high": clean_high,
            "clean_episodes": clean_episodes,
            "clean_source": clean_rows[agent][1],
        }
        for factor in sorted({key[1] for key in cells if key[0] == agent and key[1] != "clean"}):
            table += _factor_rows(cells, agent, factor, clean_fields)
    return table


def _factor_rows(
    cells: Mapping[tuple[str, str, float], list[Mapping[str, Any]]],
    agent: str,
    factor: str,
    clean_fields: Mapping[str, Any],
) -> list[dict[str, Any]]:
    """The tolerance rows of one agent and factor: one per side of the neutral level with levels flown."""
    neutral = neutral_level(factor)
    levels = sorted(level for (a, f, level) in cells if a == agent and f == factor)
    rows = []
    for side, chosen in (
        ("above", [x for x in levels if x > neutral]),
        ("below", [x for x in levels if x < neutral][::-1]),
    ):
        if chosen:
            scan = _scan_outward(chosen, [cells[(agent, factor, x)] for x in chosen], neutral, clean_fields)
            rows.append(
                {"agent": agent, "factor": factor, "side": side, **clean_fields, **scan}
                | {"thesis": THESIS_VERDICTS.get(factor, NOT_TESTED)}
            )
    return rows


def _clean_rows(
    cells: Mapping[tuple[str, str, float], list[Mapping[str, Any]]], baseline: Sequence[Mapping[str, Any]]
) -> dict[str, tuple[list[Mapping[str, Any]], str]]:
    """Per agent, its clean episodes and where they come from: the baseline's where it has any, else the
    sweep's clean cell; agents with neither are absent."""
    clean_rows: dict[str, tuple[list[Mapping[str, Any]], str]] = {}
    for row in baseline:
        if row["factor"] == "clean":
            clean_rows.setdefault(row["agent"], ([], BASELINE_SOURCE))[0].append(row)
    for (agent, factor, level), members in cells.items():
        if factor == "clean" and level == 0.0:
            clean_rows.setdefault(agent, (members, SWEEP_CLEAN_SOURCE))
    return clean_rows


def _scan_outward(
    levels: Sequence[float],
    cell_rows: Sequence[Sequence[Mapping[str, Any]]],
    neutral: float,
    clean_fields: Mapping[str, Any],
) -> dict[str, Any]:
    """One side of a factor, its ``levels`` in order outward from ``neutral`` with each level's episodes: the
    tolerated, doubling, worst and breaking levels (see :func:`tolerance_table`)."""
    clean, clean_high = clean_fields["clean_failure"], clean_fields["clean_high"]
    tolerated, doubled, broke, breaking = neutral, None, False, None
    rates = []
    for level, members in zip(levels, cell_rows, strict=True):
        rate, low, high, n = failure(members)
        rates.append((level, rate, low, high, n))
        if breaking is None and low > clean_high:
            breaking = (level, rate)
        if not broke and rate <= clean_high:
            tolerated = level
        else:
            broke = True
        if doubled is None and _doubles(rate, clean, clean_high):
            doubled = level
    worst = max(rates, key=lambda r: r[1])
    return {
        "levels": [r[0] for r in rates],
        "tolerated_level": tolerated,
        "doubling_level": doubled,
        "worst_level": worst[0],
        "worst_failure": worst[1],
        "worst_low": worst[2],
        "breaks": worst[2] > clean_high,
        "breaking_level": None if breaking is None else breaking[0],
        "breaking_failure": None if breaking is None else breaking[1],
    }


def _doubles(rate: float, clean: float, clean_high: float) -> bool:
    """Whether ``rate`` is twice the clean one and outside its interval; never where twice clean exceeds 1."""
    return 2.0 * clean <= 1.0 and rate >= 2.0 * clean and rate > clean_high


def unbroken_kind(row: Mapping[str, Any]) -> str:
    """Why no level flown breaks a tolerance row's agent: "end" (flown to the end of the setting's range),
    "easier" (no level fails more than clean: the direction makes the task easier) or "short" (the levels stop
    short of the range's end: more are needed)."""
    try:
        allowed = setting_range(row["factor"])
    except ValueError:
        allowed = None
    end = None if allowed is None else allowed.high if row["side"] == "above" else allowed.low
    if end is not None and math.isclose(row["levels"][-1], end):
        return "end"
    return "easier" if row["worst_failure"] <= row["clean_failure"] else "short"


# Agents that never read the depth histogram: their failures cannot respond to depth quality.
BLIND_AGENTS = ("straight",)


def is_flow_agent(row: Mapping[str, Any]) -> bool:
    """Whether the episode's agent steered by the estimator's depths (not an oracle's true depths, and not
    an agent blind to the histogram)."""
    if base_agent_name(row["agent"]) in BLIND_AGENTS:
        return False
    settings = row.get("env_kwargs") or ""
    if settings:
        return json.loads(settings).get("obs_source", "flow") == "flow"
    return "oracle" not in str(row["agent"])


def best_learned_flow_agent(table: Sequence[Mapping[str, Any]]) -> str | None:
    """The learned agent on flow depths with the lowest clean failure rate among a tolerance table's."""
    clean = {
        r["agent"]: r["clean_failure"]
        for r in table
        if base_agent_name(r["agent"]) in LEARNED_AGENTS and is_flow_agent({"agent": r["agent"]})
    }
    return min(clean, key=lambda agent: (clean[agent], agent)) if clean else None


def cell_quality(rows: Sequence[Mapping[str, Any]]) -> dict[tuple[str, float], dict[str, Any]]:
    """Each sensor cell's depth quality, measured on full-course flights: per (factor, level), the medians over
    the flow agents' successful episodes of :data:`DOSE_FEATURES` (log median relative depth error, valid depths
    per frame / 100, outlier share where every episode recorded it), or over all its episodes where fewer than
    :data:`MIN_FULL_COURSE` succeeded (``full_course`` False).

    An episode's own means depend on how long it flew, and a failed one is short: as a covariate of its own
    failure that is circular. A cell's quality from flights that all covered the course is a property of the
    sensor condition (the dose), the same for every episode flown in it. Task factors are left out
    (:data:`TASK_FACTORS`).
    """
    cells: dict[tuple[str, float], list[Mapping[str, Any]]] = {}
    for row in rows:
        if _measures_sensor_quality(row):
            cells.setdefault((row["factor"], float(row["level"])), []).append(row)
    every_outlier = all(
        r.get("mean_depth_outlier_share") is not None and math.isfinite(float(r["mean_depth_outlier_share"]))
        for members in cells.values()
        for r in members
    )
    quality = {}
    for key, members in cells.items():
        full = [r for r in members if bool(r["success"])]
        chosen = full if len(full) >= MIN_FULL_COURSE else members
        values = [
            float(np.median([math.log(float(r["median_depth_error"])) for r in chosen])),
            float(np.median([float(r["mean_points_valid"]) for r in chosen])) / 100.0,
        ]
        if every_outlier:
            values.append(float(np.median([float(r["mean_depth_outlier_share"]) for r in chosen])))
        quality[key] = {"values": values, "full_course": chosen is full, "episodes": len(chosen)}
    return quality


def _measures_sensor_quality(row: Mapping[str, Any]) -> bool:
    """Whether an episode counts towards its cell's depth quality: a sensor factor's (not a task factor's),
    flown by a flow agent, with a positive finite median depth error (its log is taken)."""
    error = float(row["median_depth_error"])
    return row["factor"] not in TASK_FACTORS and is_flow_agent(row) and math.isfinite(error) and error > 0


def dose_features(
    rows: Sequence[Mapping[str, Any]], quality: Mapping[tuple[str, float], Mapping[str, Any]]
) -> tuple[np.ndarray, np.ndarray, list[Mapping[str, Any]]]:
    """Design matrix (episodes, features): each episode's cell quality (:func:`cell_quality`); failures
    (episodes,); and the rows used: the episodes of cells with a quality."""
    used = [r for r in rows if (r["factor"], float(r["level"])) in quality]
    width = len(next(iter(quality.values()))["values"]) if quality else 2
    features = np.array([quality[(r["factor"], float(r["level"]))]["values"] for r in used]).reshape(
        -1, width
    )
    failures = np.array([0.0 if bool(r["success"]) else 1.0 for r in used])
    return features, failures, used


def format_p(p: float) -> str:
    """A p-value as the report prints it: two significant digits, and no smaller than :data:`P_VALUE_FLOOR`
    (beyond it the model's own assumptions, not the data, set the number)."""
    if not math.isfinite(p):
        return "–"
    return f"< {P_VALUE_FLOOR:g}" if p < P_VALUE_FLOOR else f"{p:.2g}"


def _converged_logit(
    failures: np.ndarray,
    design: np.ndarray,
    terms: str,
    method: str = "newton",
    groups: np.ndarray | None = None,
) -> Any:
    """A fitted statsmodels Logit, or ValueError where its estimate is not one: a fit that did not converge,
    whose Hessian cannot be inverted, or whose outcomes the terms separate (perfectly or nearly), where the
    coefficients run off to infinity and statsmodels only warns."""
    # statsmodels takes seconds to import: only the dose-response fits load it.
    import statsmodels.api as sm
    from statsmodels.tools.sm_exceptions import (
        ConvergenceWarning,
        HessianInversionWarning,
        PerfectSeparationWarning,
    )

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        # Episodes on one layout share its difficulty: standard errors clustered by layout.
        robust = {} if groups is None else {"cov_type": "cluster", "cov_kwds": {"groups": groups}}
        model = sm.Logit(failures, design).fit(disp=0, maxiter=200, method=method, **robust)
    problems = sorted(
        {
            "overflow" if issubclass(w.category, RuntimeWarning) else w.category.__name__
            for w in caught
            if issubclass(w.category, (ConvergenceWarning, HessianInversionWarning, PerfectSeparationWarning))
            or (issubclass(w.category, RuntimeWarning) and "overflow" in str(w.message))
        }
    )
    if problems or not model.mle_retvals.get("converged", True):
        raise ValueError(
            f"the logistic fit on {terms} has no reliable estimate ({', '.join(problems) or 'not converged'}): "
            "failures are (nearly) perfectly separated by these terms, or too few to fit them"
        )
    return model


def fit_dose_response(
    rows: Sequence[Mapping[str, Any]], quality: Mapping[tuple[str, float], Mapping[str, Any]]
) -> dict[str, Any]:
    """Logistic regression of failure on its cell's depth quality (one agent's episodes over the sensor
    factors and the clean cell), with standard errors clustered by layout, and a cluster-robust Wald test of
    adding one indicator per sensor factor.

    Returns:
        ``{"episodes", "layouts", "features", "params", "bse", "pvalues", "conf_int", "model", "wald_statistic",
        "wald_df", "wald_pvalue"}``; the model is the fitted statsmodels result of depth quality alone.

    Raises:
        ValueError: fewer than 20 usable episodes, failures that are all equal, or a feature without spread
            (nothing to fit).
    """
    # statsmodels takes seconds to import: only the dose-response fits load it.
    import statsmodels.api as sm

    features, failures, used = dose_features(rows, quality)
    if len(used) < 20 or failures.min() == failures.max():
        raise ValueError(
            f"a dose-response fit needs >= 20 episodes with a depth error and both outcomes, got {len(used)} "
            f"episodes with {int(failures.sum())} failures"
        )
    feature_names = DOSE_FEATURES[: features.shape[1]]
    flat = [name for name, column in zip(feature_names, features.T, strict=True) if np.ptp(column) == 0.0]
    if flat:
        raise ValueError(f"a dose-response fit needs spread in every feature; {', '.join(flat)} is constant")
    layouts = np.array([int(r["seed"]) for r in used])
    design = sm.add_constant(features)
    model = _converged_logit(failures, design, "depth quality", groups=layouts)
    factors = sorted({r["factor"] for r in used} - {"clean"})
    wald_statistic, wald_df, wald_pvalue = math.nan, 0, math.nan
    if factors:
        indicators = np.array([[1.0 if r["factor"] == f else 0.0 for f in factors] for r in used])
        full = _converged_logit(
            failures, np.hstack([design, indicators]), "depth quality and the factors", "bfgs", layouts
        )
        wald_statistic, wald_df, wald_pvalue = _wald(full, design.shape[1], len(factors))
    names = ["const", *feature_names]
    interval = np.asarray(model.conf_int())
    return {
        "episodes": len(used),
        "layouts": len(set(layouts.tolist())),
        "features": feature_names,
        "params": dict(zip(names, map(float, model.params), strict=True)),
        "bse": dict(zip(names, map(float, model.bse), strict=True)),
        "pvalues": dict(zip(names, map(float, model.pvalues), strict=True)),
        "conf_int": {name: (float(lo), float(hi)) for name, (lo, hi) in zip(names, interval, strict=True)},
        "model": model,
        "wald_statistic": wald_statistic,
        "wald_df": wald_df,
        "wald_pvalue": wald_pvalue,
    }


def fit_every_flow_agent(
    rows: Sequence[Mapping[str, Any]], quality: Mapping[tuple[str, float], Mapping[str, Any]]
) -> tuple[dict[str, dict[str, Any]], dict[str, str]]:
    """:func:`fit_dose_response` for each flow agent of ``rows``: the fits, and why an agent has none."""
    fits, errors = {}, {}
    for agent in sorted({r["agent"] for r in rows if is_flow_agent(r)}):
        try:
            fits[agent] = fit_dose_response([r for r in rows if r["agent"] == agent], quality)
        except ValueError as reason:
            errors[agent] = str(reason)
    return fits, errors


def _wald(model: Any, first: int, count: int) -> tuple[float, int, float]:
    """Wald test that the ``count`` coefficients from index ``first`` are all zero, with the model's own
    (cluster-robust) covariance; (statistic, degrees of freedom, p)."""

    params = np.asarray(model.params)[first : first + count]
    covariance = np.asarray(model.cov_params())[first : first + count, first : first + count]
    inverse = np.linalg.pinv(covariance)
    statistic = float(params @ inverse @ params)
    df = int(np.linalg.matrix_rank(covariance))
    return statistic, df, float(stats.chi2.sf(statistic, df))


def dose_curve(
    fit: Mapping[str, Any], errors: np.ndarray, valid_points: float, outlier_share: float = 0.0
) -> tuple[np.ndarray, ...]:
    """Predicted failure probability and its 95 % band against median depth error ``errors`` (relative),
    at ``valid_points`` valid depths per frame and (where the fit has it) ``outlier_share``."""
    columns = [np.ones(len(errors)), np.log(errors), np.full(len(errors), valid_points / 100.0)]
    if "outlier_share" in fit["features"]:
        columns.append(np.full(len(errors), outlier_share))
    design = np.column_stack(columns)
    frame = fit["model"].get_prediction(design).summary_frame()
    return (
        np.asarray(frame["predicted"]),
        np.asarray(frame["ci_lower"]),
        np.asarray(frame["ci_upper"]),
    )
