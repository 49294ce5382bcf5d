"""Replays the thesis's estimator experiments (configs/thesis/*.yaml) through FlowNav's renderer and both depth
methods, writes figures and a JSON result per experiment to results/thesis/, and rebuilds results/thesis/README.md
from every result present there."""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from agents.common.jinja_reports import render
from agents.common.locations import REPO_ROOT
from agents.common.yaml_config import load_config
from agents.evaluation.provenance import machine_summary
from agents.pages import wording
from agents.studies.thesis.comparison import table2_reading, table3_comparison, verdict_rows
from agents.studies.thesis.experiments import EXPERIMENTS
from agents.studies.thesis.motion_errors import motion_values
from agents.studies.thesis.reference import THESIS_FOCAL_PX
from agents.studies.thesis.results import ExperimentResult

DISCUSSION_FILE = "DISCUSSION.md"


def run_experiment(name: str, config_path: Path, out_dir: Path, progress: bool = True) -> ExperimentResult:
    """Load one experiment's config, run it, and write ``<out_dir>/<name>.json``.

    Args:
        name: A key of :data:`agents.studies.thesis.experiments.EXPERIMENTS`.
        config_path: Its YAML config.
        out_dir: Where figures and the JSON go.
        progress: Show progress bars.

    Returns:
        The result dict (also written as JSON).

    Raises:
        ValueError: Unknown experiment name; :class:`agents.common.yaml_config.ConfigError` for a bad config.
        FileNotFoundError: The config file does not exist.
    """
    if name not in EXPERIMENTS:
        raise ValueError(f"experiment must be one of {', '.join(EXPERIMENTS)}, got {name!r}")
    experiment = EXPERIMENTS[name]
    config = load_config(config_path, experiment.schema)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    result = experiment.runner(config, out_dir, progress=progress)
    result.update(
        {
            "name": name,
            "title": experiment.title,
            "config": _display_path(config_path),
            "camera": f"{config.camera.width}x{config.camera.height}, vertical FOV {config.camera.fov_deg:g} deg",
            "wall_s": time.perf_counter() - started,
            "hardware": machine_summary(),
        }
    )
    (out_dir / f"{name}.json").write_text(json.dumps(result, indent=1, default=_json_default))
    return result


def _display_path(path: Path) -> str:
    try:
        return str(Path(path).resolve().relative_to(REPO_ROOT))
    except ValueError:
        return str(path)


def _json_default(value: object) -> object:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)


def _experiment_values(result: ExperimentResult) -> dict[str, object]:
    """One experiment's section of the README: its JSON result with the comparisons with the thesis beside it;
    the parts an experiment lacks stay empty and the template leaves them out."""
    table2, table3, sweeps = result.get("table2"), result.get("table3"), result.get("sweeps")
    return result | {
        "verdicts": verdict_rows(sweeps) if sweeps else None,
        "table2": table2 and {"rows": table2, "reading": table2_reading(table2)},
        "table3": table3
        and {
            "comparison": table3_comparison(table3, result["rows"], result.get("fast_threshold", 20)),
            "rows": table3,
        },
    }


@dataclass(frozen=True)
class ThesisReadmeValues:
    """What ``agents/pages/templates/thesis_readme.md.j2`` states: the experiments this run ran and its wall
    time, the thesis's focal length, every experiment's section (its JSON result with the comparisons with the
    thesis beside it), the rotation- and translation-error section (None without the three-capsule result), the
    hand-written discussion (may be empty) and the machine of the first result."""

    ran: str
    wall_s: str
    thesis_focal_px: str
    experiments: list[dict[str, object]]
    motion: dict[str, object] | None
    discussion: str
    hardware: str


def readme_values(
    results: dict[str, ExperimentResult], ran: list[str], wall_s: float, discussion: str
) -> ThesisReadmeValues:
    """The README's values from every experiment's JSON result, the experiments this run ran, its wall time and
    the hand-written ``discussion``."""
    return ThesisReadmeValues(
        ran=", ".join(ran),
        wall_s=f"{wall_s:.0f}",
        thesis_focal_px=f"{THESIS_FOCAL_PX:g}",
        experiments=[_experiment_values(result) for result in results.values()],
        motion=motion_values(results["three_capsule"]) if "three_capsule" in results else None,
        discussion=discussion,
        hardware=next(iter(results.values()))["hardware"] if results else "",
    )


def write_readme(out_dir: Path, ran: list[str], wall_s: float) -> Path:
    """Rebuild ``README.md`` from every ``<name>.json`` in ``out_dir`` (and ``DISCUSSION.md`` if present)."""
    out_dir = Path(out_dir)
    files = {name: out_dir / f"{name}.json" for name in EXPERIMENTS}
    results = {name: json.loads(file.read_text()) for name, file in files.items() if file.is_file()}
    discussion = out_dir / DISCUSSION_FILE
    text = discussion.read_text().strip() if discussion.is_file() else ""
    values = readme_values(results, ran, wall_s, text)
    readme = out_dir / "README.md"
    readme.write_text(render(wording.PACKAGE, "thesis_readme.md.j2", values, every_value_used=True))
    return readme
