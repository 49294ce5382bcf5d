"""The rows of the measurements the speed and yield benchmarks (:mod:`agents.studies.perf`) report: how a
recorded flight was made, and the depth yield per estimator setting. Dictionaries, as the reports' tables format
them by key (``str.format_map``)."""

from __future__ import annotations

from typing import TypedDict


class FlightDescription(TypedDict):
    """How a flight was made: the field layout and its seed, the frames and their size, the camera's vertical
    field of view (degrees), the frame rate (Hz) and the forward speed (m/s)."""

    layout: str
    seed: int
    frames: int
    width: int
    height: int
    fov_deg: float
    frame_rate: float
    forward_speed: float


class YieldSummary(TypedDict):
    """An estimator variant's depth yield over its flights: frames flown, valid depths per frame (and in the
    central third of the image), the median, share within 10 % and 90th percentile of the relative depth error,
    and the estimator's median time per frame (ms)."""

    variant: str
    steps: int
    valid_per_frame: float
    central_per_frame: float
    median_rel_error: float
    within_10pct: float
    p90_rel_error: float
    estimator_ms: float


class YieldBand(TypedDict):
    """An estimator variant's valid depths per frame and their median relative error (NaN: none) whose true
    depth lies in the band [low, high) metres."""

    variant: str
    band: tuple[float, float]
    valid_per_frame: float
    median_rel_error: float


class StageMeasurement(TypedDict):
    """One training stage of a recipe, measured once: its work per seed by kind (counts) and its measured times
    (seconds per step, per episode, per state-epoch and at start-up)."""

    work: dict[str, int]
    measured: dict[str, float]


class RecipeBlock(TypedDict):
    """A recipe measured once (one block of the alternation): minutes per seed by kind of work and in total, and
    each stage's measurement."""

    minutes: dict[str, float]
    total: float
    stages: list[StageMeasurement]


class RecipeQuality(TypedDict):
    """A recipe's last stage on the validation layouts: per condition, its failure over runs × layouts and its
    number of seeds (None: not flown there), and whether it meets the bar (None: not flown under every one)."""

    rates: dict[str, tuple[float, int] | None]
    meets: bool | None
