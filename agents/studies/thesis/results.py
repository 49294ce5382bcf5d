"""What a thesis experiment's runner returns and ``results/thesis/<name>.json`` holds: the rows of each table it
measured and the figures it drew (``report.py`` adds the run's own facts and words the README from them)."""

from __future__ import annotations

from typing import TYPE_CHECKING, TypedDict

from agents.studies.thesis.metrics import MetricRow

if TYPE_CHECKING:  # typing has it from Python 3.11; annotations are not evaluated at run time
    from typing import NotRequired


class TimingRow(TypedDict):
    """A method's stage timed per frame (Table 3): its mean and median, in milliseconds."""

    method: str
    stage: str
    mean_ms: float
    median_ms: float


class ThesisRotationQuote(TypedDict):
    """A row of the thesis's Table 2 as a case quotes it (``ThesisRotationCase``): its Unity angles and what it
    measured (None: every point an outlier)."""

    test: int
    unity_deg: list[float]
    mean_px: float
    mean_inliers_px: float | None
    points: int
    points_inliers: int


class Table2Row(TypedDict):
    """One pure rotation of Table 2 (``rotation.py``): the case, its frame pairs and angles flown, the thesis's
    row it quotes (absent: none), the mean residual after compensating with the exact rotation (``matrix``) and
    with the thesis's Euler derotation (``euler``), with and without outliers, and the outliers; the residual
    uncompensated, the points detected and tracked (of the Euler pass), and what an Euler-order mix-up moves a
    point (px)."""

    case: str
    frame_pairs: int
    flown_deg: list[float]
    thesis: NotRequired[ThesisRotationQuote]
    matrix_mean_px: float
    matrix_mean_inliers_px: float
    matrix_outliers: int
    uncompensated_mean_px: float
    detected: int
    tracked: int
    euler_mean_px: float
    euler_mean_inliers_px: float
    euler_outliers: int
    euler_order_shift_px: float


class SweepRow(MetricRow):
    """A method's row of a three-capsule run with one test variable set to ``value``."""

    variable: str
    value: float


class MotionMeasure(TypedDict):
    """The three-capsule run's rotation per frame, attitude and parallax (medians; per axis where named), and
    the angular instability it flew with (``jitter_deg``)."""

    focal_px: float
    frame_pairs: int
    rotation_deg_median: float
    rotation_axis_deg_median: list[float]
    attitude_deg_median: float
    attitude_axis_deg_median: list[float]
    unity_readout_deg_median: float
    capsule_parallax_px_median: float
    capsule_parallax_px_p25: float
    capsule_points: int
    jitter_deg: float


class ExperimentResult(TypedDict, total=False):
    """An experiment's JSON result: what its runner measured (each experiment fills its own keys: ``rows`` and
    ``figures`` always; Table 2's cases, Table 3's timings, the sweeps and motion of the three-capsule run),
    then the facts of the run (name, title, config, camera, wall time, machine)."""

    rows: list[MetricRow]
    figures: list[str]
    table2: list[Table2Row]
    focal_px: float
    table3: list[TimingRow]
    fast_threshold: int
    sweeps: list[SweepRow]
    motion: MotionMeasure
    recorded_frames: int
    recorded_length_m: float
    obstacles: list[list[float]]
    name: str
    title: str
    config: str
    camera: str
    wall_s: float
    hardware: str
