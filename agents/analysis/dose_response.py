"""The dose-response half of the error analysis (:mod:`agents.studies.error_analysis` holds the tolerance table,
and words both):
episode failure against its cell's depth quality (:func:`cell_quality`: median relative
depth error, valid depths per frame and, where recorded, the share of depths off by more than half, measured
on the cell's full-course flights so that no episode's covariate depends on its own length), pooled over the
sensor factors' cells and the clean one, fitted as a logistic regression (statsmodels) with standard errors
clustered by layout. A second fit adds one indicator per sensor factor; a cluster-robust Wald test of those
indicators says whether the factors act on failures through more than the measured depth quality (e.g. the
drone's motion, or what the estimator cannot measure). Task factors (:data:`TASK_FACTORS`) change the task
itself and are left out of both. p-values are printed no smaller than :data:`P_VALUE_FLOOR`.

Agents on oracle observations are left out: their observation is not the estimate.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Protocol, TypedDict

import numpy as np
from scipy import stats

from agents.analysis.episode_record import EpisodeRow, is_flow_agent

if TYPE_CHECKING:
    import pandas as pd

# Depth quality per episode: log median relative error, valid depths per frame (in hundreds), and the share of
# depths off by more than half, where the episodes recorded it (not in files from before it existed).
DOSE_FEATURES = ("log_depth_error", "valid_points_per_100", "outlier_share")
# A cell's quality is measured on its successful (full-course) episodes when it has at least this many.
MIN_FULL_COURSE = 5
P_VALUE_FLOOR = 1e-6
# Factors that change the task itself (how fast, how cluttered, how visible), not what the drone is told or
# estimates: "they matter beyond depth quality" would be true of them by construction, so the dose-response
# fits and their test use the sensor factors only.
TASK_FACTORS = ("forward_speed", "obstacle_density", "brightness")


class CellQuality(TypedDict):
    """A sensor cell's depth quality (:func:`cell_quality`): the medians of :data:`DOSE_FEATURES` it has
    (``values``), whether they come from full-course flights, and over how many episodes."""

    values: list[float]
    full_course: bool
    episodes: int


class Prediction(Protocol):
    """What the dose curve reads of a statsmodels prediction (statsmodels ships no types)."""

    def summary_frame(self) -> pd.DataFrame: ...


class FittedLogit(Protocol):
    """What is read here of a fitted statsmodels Logit (statsmodels ships no types): its coefficients, their
    standard errors, p-values, intervals and covariance, how the fit went, and predictions."""

    params: np.ndarray
    bse: np.ndarray
    pvalues: np.ndarray
    mle_retvals: dict[str, object]

    def conf_int(self) -> np.ndarray: ...

    def cov_params(self) -> np.ndarray: ...

    def get_prediction(self, exog: np.ndarray) -> Prediction: ...


class DoseFit(TypedDict):
    """One agent's dose-response fit (:func:`fit_dose_response`): its episodes and layouts, the features, each
    coefficient's estimate, standard error, p-value and 95 % interval by name (``const`` and the features),
    the fitted model of depth quality alone, and the Wald test of the sensor factors' indicators."""

    episodes: int
    layouts: int
    features: tuple[str, ...]
    params: dict[str, float]
    bse: dict[str, float]
    pvalues: dict[str, float]
    conf_int: dict[str, tuple[float, float]]
    model: FittedLogit
    wald_statistic: float
    wald_df: int
    wald_pvalue: float


def cell_quality(rows: Sequence[EpisodeRow]) -> dict[tuple[str, float], CellQuality]:
    """Each sensor cell's depth quality, measured on full-course flights: per (factor, level), the medians over
    the flow agents' successful episodes of :data:`DOSE_FEATURES` (log median relative depth error, valid depths
    per frame / 100, outlier share where every episode recorded it), or over all its episodes where fewer than
    :data:`MIN_FULL_COURSE` succeeded (``full_course`` False).

    An episode's own means depend on how long it flew, and a failed one is short: as a covariate of its own
    failure that is circular. A cell's quality from flights that all covered the course is a property of the
    sensor condition (the dose), the same for every episode flown in it. Task factors are left out
    (:data:`TASK_FACTORS`).
    """
    cells: dict[tuple[str, float], list[EpisodeRow]] = {}
    for row in rows:
        if _measures_sensor_quality(row):
            cells.setdefault((row["factor"], float(row["level"])), []).append(row)
    every_outlier = all(math.isfinite(_outlier_share(r)) for members in cells.values() for r in members)
    quality: dict[tuple[str, float], CellQuality] = {}
    for key, members in cells.items():
        full = [r for r in members if bool(r["success"])]
        chosen = full if len(full) >= MIN_FULL_COURSE else members
        values = [
            float(np.median([math.log(float(r["median_depth_error"])) for r in chosen])),
            float(np.median([float(r["mean_points_valid"]) for r in chosen])) / 100.0,
        ]
        if every_outlier:
            values.append(float(np.median([_outlier_share(r) for r in chosen])))
        quality[key] = {"values": values, "full_course": chosen is full, "episodes": len(chosen)}
    return quality


def _outlier_share(row: EpisodeRow) -> float:
    """The episode's outlier share; NaN in files from before it was recorded."""
    share = row.get("mean_depth_outlier_share")
    return math.nan if share is None else float(share)


def _measures_sensor_quality(row: EpisodeRow) -> bool:
    """Whether an episode counts towards its cell's depth quality: a sensor factor's (not a task factor's),
    flown by a flow agent, with a positive finite median depth error (its log is taken)."""
    error = float(row["median_depth_error"])
    return row["factor"] not in TASK_FACTORS and is_flow_agent(row) and math.isfinite(error) and error > 0


def dose_features(
    rows: Sequence[EpisodeRow], quality: Mapping[tuple[str, float], CellQuality]
) -> tuple[np.ndarray, np.ndarray, list[EpisodeRow]]:
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
) -> FittedLogit:
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
    rows: Sequence[EpisodeRow], quality: Mapping[tuple[str, float], CellQuality]
) -> DoseFit:
    """Logistic regression of failure on its cell's depth quality (one agent's episodes over the sensor
    factors and the clean cell), with standard errors clustered by layout, and a cluster-robust Wald test of
    adding one indicator per sensor factor.

    Returns:
        A :class:`DoseFit`; its model is the fitted statsmodels result of depth quality alone.

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
    rows: Sequence[EpisodeRow], quality: Mapping[tuple[str, float], CellQuality]
) -> tuple[dict[str, DoseFit], dict[str, str]]:
    """:func:`fit_dose_response` for each flow agent of ``rows``: the fits, and why an agent has none."""
    fits: dict[str, DoseFit] = {}
    errors: dict[str, str] = {}
    for agent in sorted({r["agent"] for r in rows if is_flow_agent(r)}):
        try:
            fits[agent] = fit_dose_response([r for r in rows if r["agent"] == agent], quality)
        except ValueError as reason:
            errors[agent] = str(reason)
    return fits, errors


def _wald(model: FittedLogit, first: int, count: int) -> tuple[float, int, float]:
    """Wald test that the ``count`` coefficients from index ``first`` are all zero, with the model's own
    (cluster-robust) covariance; (statistic, degrees of freedom, p)."""

    params = np.asarray(model.params)[first : first + count]
    covariance = np.asarray(model.cov_params())[first : first + count, first : first + count]
    inverse = np.linalg.pinv(covariance)
    statistic = float(params @ inverse @ params)
    df = int(np.linalg.matrix_rank(covariance))
    return statistic, df, float(stats.chi2.sf(statistic, df))


def dose_curve(
    fit: DoseFit, errors: np.ndarray, valid_points: float, outlier_share: float = 0.0
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
