"""Depth yield at equal accuracy: how many valid depths per frame an estimator setting gives, and how good they
are, in FlowNav flights against the ray-cast truth.

``flownav bench yield --out results`` writes ``depth_yield.md`` and ``depth_yield.png``. An accuracy benchmark, not
a speed one: the estimator's time per frame is a side note. The flights are validation layouts, so settings may be
chosen from it.
"""

from __future__ import annotations

import itertools
import math
import shlex
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np
from tqdm import tqdm

from agents.analysis.perf_rows import YieldBand, YieldSummary
from agents.common.seeds import VALIDATION_SEED_START
from agents.common.tables import markdown_table
from agents.studies.perf.flight import scripted_action
from agents.studies.perf.report_kit import RunFacts, saved_figure, table, write_report
from estimator import CameraIntrinsics, FlowDepthEstimator
from estimator.accuracy import relative_depth_error
from flownav_env import FlowNavEnv
from flownav_env.settings import EnvSettings

#: True-depth bands (m) of the in-scene breakdown: near obstacles, the course ahead, far, very far.
DEPTH_BANDS: tuple[float, ...] = (0.0, 2.0, 4.0, 8.0, math.inf)
#: Flights start from these validation seeds (the ones the throughput work used), one per flight.
FLIGHT_SEED_START = VALIDATION_SEED_START
#: The "more valid depths per frame" lever's settings beside the FAST threshold: looser forward-backward, parallax,
#: epipolar and LK-error limits.
DEFAULT_SETTINGS: tuple[str, ...] = (
    "fb_max_error_px=1.0",
    "min_parallax_px=0.5",
    "max_epipolar_error_px=1.5",
    "max_lk_error=8",
    "fast_threshold=5;baseline_frames=4",
)


def scene_rows(
    variants: Mapping[str, Mapping[str, object]], flights: int, steps: int, progress: bool = True
) -> tuple[list[YieldSummary], list[YieldBand]]:
    """Scripted FlowNav flights (160×120, defaults) per named estimator variant (``estimator_kwargs`` over the
    env's), every valid depth against the ray-cast truth at its pixel in the previous camera.

    Returns:
        ``(summary, bands)``: one summary row per variant; one row per (variant, true-depth band).
    """
    summary, bands = [], []
    jobs = [(name, flight) for name in variants for flight in range(flights)]
    samples: dict[str, dict[str, list[Any]]] = {
        name: {key: [] for key in ("error", "truth", "valid", "central", "ms")} for name in variants
    }
    for name, flight in tqdm(jobs, desc="flights", unit="flight", disable=not progress):
        env = FlowNavEnv(estimator_kwargs=variants[name], depth_error_info=False)
        env.reset(seed=FLIGHT_SEED_START + flight)
        width = env.intrinsics.width
        sample = samples[name]
        for step in range(steps):
            previous_pose = env.physics.camera_pose()
            _, _, terminated, truncated, _ = env.step(scripted_action(step))
            points = env.last_depth_points
            if points is None:
                raise RuntimeError("FlowNavEnv.step left no depth points")
            valid = points.valid
            truth = env.physics.ray_depths(env.intrinsics.rays(points.points[valid]), *previous_pose)
            known = np.isfinite(truth)
            sample["error"].append(relative_depth_error(points.depth[valid][known], truth[known]))
            sample["truth"].append(truth[known])
            central = np.abs(points.points[valid][:, 0] - (width - 1) / 2) < width / 6
            sample["valid"].append(int(valid.sum()))
            sample["central"].append(int(central.sum()))
            sample["ms"].append(1000.0 * points.timings["total"])
            if terminated or truncated:
                break
        env.close()
    for name, sample in samples.items():
        error, truth = np.concatenate(sample["error"]), np.concatenate(sample["truth"])
        steps_flown = len(sample["valid"])
        summary.append(
            YieldSummary(
                variant=name,
                steps=steps_flown,
                valid_per_frame=float(np.mean(sample["valid"])),
                central_per_frame=float(np.mean(sample["central"])),
                median_rel_error=float(np.median(error)),
                within_10pct=float(np.mean(error <= 0.1)),
                p90_rel_error=float(np.quantile(error, 0.9)),
                estimator_ms=float(np.median(sample["ms"])),
            )
        )
        for low, high in itertools.pairwise(DEPTH_BANDS):
            band = (truth >= low) & (truth < high)
            bands.append(
                YieldBand(
                    variant=name,
                    band=(low, high),
                    valid_per_frame=float(band.sum() / steps_flown),
                    median_rel_error=float(np.median(error[band])) if band.any() else float("nan"),
                )
            )
    return summary, bands


def variant_settings(
    baseline_frames: Sequence[int], fast_thresholds: Sequence[int], settings: Sequence[str]
) -> dict[str, dict[str, object]]:
    """Named estimator variants: the default, one per ``baseline_frames`` and FAST threshold, and one per
    ``KEY=VALUE[;KEY=VALUE...]`` setting (integers as ints, other numbers as floats, ``a,b`` as a pair)."""
    variants: dict[str, dict[str, object]] = {"default": {}}
    variants |= {f"baseline_frames={k}": {"baseline_frames": k} for k in baseline_frames if k != 1}
    variants |= {f"fast_threshold={value}": {"fast_threshold": value} for value in fast_thresholds}
    for setting in settings:
        variant: dict[str, object] = {}
        for part in setting.split(";"):
            key, sep, text = part.partition("=")
            if not sep or not key.strip() or not text.strip():
                raise ValueError(f"settings must be KEY=VALUE[;KEY=VALUE...], got {setting!r}")
            variant[key.strip()] = _setting_value(text.strip())
        variants[setting] = variant
    return variants


def run_depth_yield(
    baseline_frames: Sequence[int],
    fast_thresholds: Sequence[int],
    settings: Sequence[str],
    flights: int,
    steps: int,
    out_dir: Path,
    progress: bool = True,
) -> list[Path]:
    """Measure, then write ``depth_yield.md`` and ``depth_yield.png`` to ``out_dir``.

    Raises:
        ValueError: A baseline is outside [1, 16], ``flights`` or ``steps`` is below 1, a setting is not
            ``KEY=VALUE``, or the estimator refuses a variant (its message names the setting and its range).
    """
    if any(not 1 <= frames <= 16 for frames in baseline_frames):
        raise ValueError(f"baseline frames must each be in [1, 16], got {list(baseline_frames)}")
    if flights < 1 or steps < 1:
        raise ValueError(f"flights and steps must be >= 1, got {flights} and {steps}")
    variants = variant_settings(baseline_frames, fast_thresholds, settings)
    for name, kwargs in variants.items():  # refuse a bad setting before flying anything
        try:
            # Any value may come in: the estimator refuses what it does not take.
            FlowDepthEstimator(CameraIntrinsics.from_fov(64, 48, 60.0), **cast("dict[str, Any]", kwargs))
        except TypeError as error:
            raise ValueError(f"variant {name!r}: {error}") from None
    started = time.perf_counter()
    summary, bands = scene_rows(variants, flights, steps, progress)
    out_dir.mkdir(parents=True, exist_ok=True)
    figure = out_dir / "depth_yield.png"
    _plot(bands, figure)
    command = f"flownav bench yield --frames {','.join(map(str, baseline_frames))} --fast-thresholds "
    command += ",".join(map(str, fast_thresholds)) + "".join(
        f" --setting {shlex.quote(setting)}" for setting in settings
    )
    command += f" --flights {flights} --steps {steps} --out {out_dir}"
    values = yield_report_values(summary, bands, RunFacts.of_this_run(command, started))
    return [write_report(out_dir / "depth_yield.md", "depth_yield.md.j2", values), figure]


def _setting_value(text: str) -> tuple[int, ...] | int | float:
    """``a,b`` → a pair of integers; an integer literal → int (the estimator refuses 5.0 for a count); else float."""
    if "," in text:
        return tuple(int(part) for part in text.split(","))
    try:
        return int(text)
    except ValueError:
        return float(text)


def _by_band(bands: Sequence[YieldBand]) -> tuple[list[str], dict[str, list[YieldBand]]]:
    """The true-depth bands' names, and each variant's rows in band order."""
    names = [
        f"≥ {low:g} m" if math.isinf(high) else f"{low:g}–{high:g} m"
        for low, high in dict.fromkeys(row["band"] for row in bands)
    ]
    variants: dict[str, list[YieldBand]] = {}
    for row in bands:
        variants.setdefault(row["variant"], []).append(row)
    return names, variants


@dataclass(frozen=True)
class YieldReportValues:
    """Every value ``templates/depth_yield.md.j2`` words: the run's facts, the env's FAST threshold, the
    scene's frame size, the flights' first seed, and the summary and per-band tables."""

    run: RunFacts
    env_fast_threshold: int
    scene_size: str
    first_seed: str
    summary_table: str
    band_table: str


def yield_report_values(
    summary: Sequence[YieldSummary], bands: Sequence[YieldBand], run: RunFacts
) -> YieldReportValues:
    """The report's values from :func:`scene_rows`' summary and bands, and the run's facts."""
    defaults = EnvSettings()
    summary_columns = {
        "variant": "{variant}",
        "steps": "{steps}",
        "valid / frame": "{valid_per_frame:.1f}",
        "in the central third": "{central_per_frame:.1f}",
        "median error": "{median_rel_error:.2%}",
        "within 10 %": "{within_10pct:.1%}",
        "p90 error": "{p90_rel_error:.1%}",
        "estimator ms (median)": "{estimator_ms:.2f}",
    }
    band_names, variants = _by_band(bands)
    by_band = [
        [name, *(f"{row['valid_per_frame']:.1f} / {row['median_rel_error']:.1%}" for row in rows)]
        for name, rows in variants.items()
    ]
    return YieldReportValues(
        run=run,
        env_fast_threshold=defaults.estimator_arguments()["fast_threshold"],
        scene_size=f"{defaults.camera_width}×{defaults.camera_height}",
        first_seed=f"{FLIGHT_SEED_START:,}",
        summary_table=table(summary, summary_columns),
        band_table=markdown_table(["variant", *band_names], by_band),
    )


def _plot(bands: Sequence[YieldBand], path: Path) -> None:
    names, variants = _by_band(bands)
    width, x = 0.8 / len(variants), np.arange(len(names))
    with saved_figure(path, (12, 4.5)) as figure:
        count_axis, error_axis = figure.subplots(1, 2)
        for index, (name, rows) in enumerate(variants.items()):
            offset = x + (index - (len(variants) - 1) / 2) * width
            count_axis.bar(offset, [row["valid_per_frame"] for row in rows], width, label=name)
            error_axis.bar(offset, [100 * row["median_rel_error"] for row in rows], width, label=name)
        for axis, title in (
            (count_axis, "valid depths per frame"),
            (error_axis, "median relative error (%)"),
        ):
            axis.set_xticks(x, names)
            axis.set_xlabel("true depth")
            axis.set_title(title)
        count_axis.legend(fontsize=7)
        figure.suptitle(
            "Valid depths and their error by true depth, per estimator variant (FlowNav flights, 160×120)"
        )
