"""Replays the thesis's estimator experiments (configs/thesis/*.yaml) through FlowNav's renderer and both depth
methods, writes figures and a JSON result per experiment to results/thesis/, and rebuilds results/thesis/README.md
from every result present there."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import Any

from agents.common.locations import REPO_ROOT
from agents.common.yaml_config import load_config
from agents.evaluation.provenance import machine_summary
from agents.studies.thesis.comparison import table2_comparison, table3_comparison, verdict_table
from agents.studies.thesis.experiments import EXPERIMENTS
from agents.studies.thesis.motion_errors import motion_error_section


def run_experiment(name: str, config_path: Path, out_dir: Path, progress: bool = True) -> dict[str, Any]:
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
            "thesis": experiment.thesis,
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


def _json_default(value: Any) -> Any:
    import numpy as np

    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)


# --- the README ------------------------------------------------------------------------------------------------
def _pct(value: float) -> str:
    return (
        "–" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{100 * value:.1f} %"
    )


def _num(value: float, digits: int = 1) -> str:
    return "–" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.{digits}f}"


def metrics_table(rows: list[dict[str, Any]], first: str = "run") -> list[str]:
    """Markdown table of depth metric rows (one per run and method)."""
    lines = [
        f"| {first} | method | median abs. rel. depth error | within 10 % | valid points / frame | tracked / frame "
        "| median error, capsule points only | capsule points / frame | evaluated points |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        lines.append(
            f"| {row.get(first, row['run'])} | {row['method']} | {_pct(row['median_rel_error'])} | "
            f"{_pct(row['within_10pct'])} | {_num(row['valid_per_frame'])} | {_num(row['tracked_per_frame'])} | "
            f"{_pct(row['obstacle_median_rel_error'])} | {_num(row['obstacle_valid_per_frame'])} | {row['evaluated']} |"
        )
    return lines


def _table2(rows: list[dict[str, Any]]) -> list[str]:
    lines = [
        "| case | frame pairs | points detected | points tracked | mean \\|p2 − p2′\\| incl. outliers (px) "
        "| excl. outliers (px) | outliers (> 5 px) | Euler-angle derotation (thesis), incl. / excl. (px) "
        "| Euler order (px) | mean \\|p2 − p1\\| without compensation (px) |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['case']} | {r['frame_pairs']} | {r['detected']} | {r['tracked']} | {_num(r['matrix_mean_px'], 3)} | "
            f"{_num(r['matrix_mean_inliers_px'], 3)} | {r['matrix_outliers']} | {_num(r['euler_mean_px'], 3)} / "
            f"{_num(r['euler_mean_inliers_px'], 3)} | {_num(r.get('euler_order_shift_px', math.nan), 2)} | "
            f"{_num(r['uncompensated_mean_px'], 2)} |"
        )
    return lines


def _table3(rows: list[dict[str, Any]]) -> list[str]:
    lines = ["| method | stage | mean (ms) | median (ms) |", "|---|---|---|---|"]
    lines += [f"| {r['method']} | {r['stage']} | {r['mean_ms']:.2f} | {r['median_ms']:.2f} |" for r in rows]
    return lines


def _sweep_table(rows: list[dict[str, Any]]) -> list[str]:
    lines = [
        "| variable | value | method | median abs. rel. depth error | within 10 % | valid points / frame "
        "| median error, capsule points only | frames |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['variable']} | {r['value']:g} | {r['method']} | {_pct(r['median_rel_error'])} | "
            f"{_pct(r['within_10pct'])} | {_num(r['valid_per_frame'])} | {_pct(r['obstacle_median_rel_error'])} | "
            f"{r['frames']} |"
        )
    return lines


DISCUSSION_FILE = "DISCUSSION.md"


def _experiment_section(name: str, result: dict[str, Any]) -> list[str]:
    """One experiment's section of the README: its claim, config, tables, sweeps and figures."""
    lines = [
        f"## {result['title']}",
        "",
        f"*Thesis:* {result['thesis']}",
        "",
        f"Config `{result['config']}`; camera {result['camera']}; wall time {result['wall_s']:.1f} s; "
        f"`flownav replicate --only {name}`.",
        "",
    ]
    if name == "three_capsule":
        lines += [
            f"Recorded base flight: {result['recorded_frames']} frames, {result['recorded_length_m']:.2f} m; "
            f"capsules at {', '.join(f'({x:.2f}, {y:.2f})' for x, y in result['obstacles'])} m "
            "(saved as `three_capsule_path.npz`, format in `flownav_env/playback/path.py`).",
            "",
        ]
    if name == "three_capsule" and result.get("sweeps"):
        lines += [
            "The thesis's verdicts on its variable tests beside FlowNav's rows:",
            "",
            *verdict_table(result["sweeps"]),
            "",
        ]
    if result.get("rows"):
        lines += [*metrics_table(result["rows"]), ""]
    if result.get("table2"):
        lines += [
            "Table 2, the thesis beside FlowNav (the thesis: one frame pair per case at f = 417 px; "
            f"FlowNav: f = {result.get('focal_px', math.nan):.1f} px, the mean over 5 frame pairs):",
            "",
            *table2_comparison(result["table2"], result.get("focal_px", math.nan)),
            "",
            "FlowNav's Table 2 in full (rotation-matrix derotation; the `thesis` method's Euler-angle "
            "derotation beside it; *Euler order*: how far composing the case's angles in eq. 4.15's Z-Y-X "
            "order instead of Unity's z-x-y moves the points):",
            "",
            *_table2(result["table2"]),
            "",
        ]
    if result.get("table3"):
        lines += [
            "Table 3, the thesis beside FlowNav: the thesis's rows at our FAST threshold and at our number of "
            "points used (other machine, other scene; FlowNav's estimator alone, rendering excluded):",
            "",
            *table3_comparison(result["table3"], result["rows"], result.get("fast_threshold", 20)),
            "",
        ]
        lines += [
            "Table 3 (per-stage time per frame pair of the estimator on this path, from `DepthPoints.timings`; "
            "render = placing the camera and rendering one frame):",
            "",
            *_table3(result["table3"]),
            "",
        ]
    if result.get("sweeps"):
        lines += [
            "Sweeps (one variable changed from the base run):",
            "",
            *_sweep_table(result["sweeps"]),
            "",
        ]
    lines += [f"![{name}]({figure})" for figure in result.get("figures", [])] + [""]
    return lines


def write_readme(out_dir: Path, ran: list[str], wall_s: float) -> Path:
    """Rebuild ``README.md`` from every ``<name>.json`` in ``out_dir`` (and ``DISCUSSION.md`` if present)."""
    out_dir = Path(out_dir)
    results = {}
    for name in EXPERIMENTS:
        file = out_dir / f"{name}.json"
        if file.is_file():
            results[name] = json.loads(file.read_text())
    lines = [
        "# Thesis experiments reproduced in FlowNav",
        "",
        "Produced by `flownav replicate` (all five experiments; `flownav replicate --only NAME` reruns one and "
        "rebuilds this file from the JSON results beside it). Configs: `configs/thesis/<name>.yaml`. "
        "Figures: the thesis's style, each valid point's estimated depth per frame (dots, coloured by the "
        "capsule its ray actually hits; grey = ground) against the true depth of each capsule's facing "
        "surface (lines).",
        "",
        f"Last invocation ran: {', '.join(ran)} in {wall_s:.0f} s wall time.",
        "",
        "Metrics, per run and method: *median absolute relative depth error* |d − d_true| / d_true over all "
        "valid points (d_true: exact z-depth by ray casting at the keypoint in the scene), *within 10 %*: share "
        "of those points with error ≤ 10 %, *valid points / frame*: mean per estimated frame pair. Both depth "
        "methods of `estimator.FlowDepthEstimator` run on the same rendered frames: `thesis` (Euler-angle "
        "derotation, per point the larger flow component, eqs. 4.12/4.15/4.18) and `triangulation` (least "
        "squares over both components).",
        "",
    ]
    discussion = out_dir / DISCUSSION_FILE
    for name, result in results.items():
        lines += _experiment_section(name, result)
    if "three_capsule" in results:
        lines += motion_error_section(results["three_capsule"])
    if discussion.is_file():
        lines += [discussion.read_text().strip(), ""]
    if results:
        lines += ["## Hardware", "", next(iter(results.values()))["hardware"], ""]
    readme = out_dir / "README.md"
    readme.write_text("\n".join(lines))
    return readme
