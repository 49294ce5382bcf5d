"""What a thesis experiment's runner returns and ``results/thesis/<name>.json`` holds: the rows of each table it
measured and the figures it drew (``report.py`` adds the run's own facts and words the README from them)."""

from __future__ import annotations

from typing import TypedDict

from agents.studies.thesis.metrics import MetricRow


class TimingRow(TypedDict):
    """A method's stage timed per frame (Table 3): its mean and median, in milliseconds."""

    method: str
    stage: str
    mean_ms: float
    median_ms: float


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
    table2: list[dict[str, object]]
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
