"""agents.thesis: a tiny experiment end to end, kernels, config validation."""

from __future__ import annotations

import json

import numpy as np
import pytest

from agents.cli.replicate import EXPERIMENT_NAMES
from agents.common.config import ConfigError, load_config
from agents.common.paths import CONFIGS_DIR
from agents.thesis.configs import StraightConfig
from agents.thesis.experiments import EXPERIMENTS
from agents.thesis.metrics import component_depth, depth_metrics
from agents.thesis.report import run_experiment, write_readme
from estimator import CameraIntrinsics
from estimator.geometry import project_points

CONFIGS = CONFIGS_DIR / "thesis"

TINY_STRAIGHT = """
camera: {width: 128, height: 96, fov_deg: 60.0}
obstacles:
  - {x: 4.0, y: 0.0, material: 4}
start: [0.0, 0.0, 1.0]
distance_per_frame: 0.1
frames: 4
"""


def test_shipped_configs_load() -> None:
    assert EXPERIMENT_NAMES == tuple(EXPERIMENTS)  # the CLI's choices, listed there for an instant --help
    for name in EXPERIMENT_NAMES:
        load_config(CONFIGS / f"{name}.yaml", EXPERIMENTS[name].schema)


def test_tiny_straight_experiment_end_to_end(tmp_path) -> None:
    config = tmp_path / "straight.yaml"
    config.write_text(TINY_STRAIGHT)
    result = run_experiment("straight", config, tmp_path / "out", progress=False)
    assert (tmp_path / "out" / "straight.png").is_file()
    saved = json.loads((tmp_path / "out" / "straight.json").read_text())
    assert {row["method"] for row in saved["rows"]} == {"x-flow", "y-flow", "thesis", "triangulation"}
    by_method = {row["method"]: row for row in result["rows"]}
    assert by_method["triangulation"]["frames"] == 3
    assert by_method["triangulation"]["valid_per_frame"] > 0
    # 128x96 leaves only a few pixels of parallax (2 % measured): a loose bound; the full run measures accuracy.
    assert by_method["triangulation"]["median_rel_error"] < 0.1
    readme = write_readme(tmp_path / "out", ["straight"], 1.0).read_text()
    assert "median abs. rel. depth error" in readme and "flownav replicate --only straight" in readme


def test_component_depth_is_exact_for_exact_flow() -> None:
    intrinsics = CameraIntrinsics.from_fov(64, 48, 60.0)
    points = np.array([[1.0, 0.5, 4.0], [-0.8, 0.3, 3.0], [0.4, -0.6, 5.0]])
    rotation = np.eye(3)
    translation = np.array([0.1, 0.05, -0.2])
    prev = project_points(points)
    nxt = project_points(points @ rotation.T + translation)
    for component in (0, 1):
        depth, parallax = component_depth(prev, nxt, rotation, translation, intrinsics.focal_scale, component)
        np.testing.assert_allclose(depth, points[:, 2], rtol=1e-12)
        assert np.all(parallax > 0)
    with pytest.raises(ValueError, match="component must be 0"):
        component_depth(prev, nxt, rotation, translation, intrinsics.focal_scale, 2)


def test_depth_metrics() -> None:
    frame = {
        "depth": np.array([1.05, 2.0, 3.6, 9.0]),
        "true_depth": np.array([1.0, 2.0, 3.0, np.nan]),
        "valid": np.array([True, True, True, False]),
        "labels": np.array([0, -1, 0, -2]),
        "tracked": 4,
    }
    metrics = depth_metrics([frame])
    assert metrics["median_rel_error"] == pytest.approx(0.05)
    assert metrics["within_10pct"] == pytest.approx(2 / 3)
    assert (metrics["valid_per_frame"], metrics["evaluated"]) == (3.0, 3)
    assert depth_metrics([frame], obstacles_only=True)["evaluated"] == 2


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("frames: 2", "key 'frames' must be in [3, 10000], got 2"),
        ("frames: many", "key 'frames' must be an integer, got 'many'"),
        ("distance_per_frame: 5.0", "key 'distance_per_frame' must be in [0.001, 1.0], got 5.0"),
        ("camera: {width: 8}", "key 'camera.width': camera_width must be an integer in [16, 1280], got 8"),
        ("obstacles: [{x: 1.0, material: 9}]", "key 'obstacles[0].material' must be in [0, 5], got 9"),
        ("speed: 1.0", "unknown key 'speed'"),
        ("estimator: {method: thesis}", "key 'estimator.method' is not allowed"),
        ("estimator: {win_size: 1}", "key 'estimator.win_size'"),
        ("estimator: {no_such_kwarg: 1}", "key 'estimator'"),
    ],
)
def test_bad_config_raises_config_error_naming_file_and_key(tmp_path, text, message) -> None:
    config = tmp_path / "bad.yaml"
    config.write_text(text)
    with pytest.raises(ConfigError) as error:
        load_config(config, StraightConfig)
    assert isinstance(error.value, ValueError)
    assert str(config) in str(error.value) and message in str(error.value)


def test_unknown_experiment_and_missing_config(tmp_path) -> None:
    with pytest.raises(ValueError, match="experiment must be one of"):
        run_experiment("nope", tmp_path / "x.yaml", tmp_path)
    with pytest.raises(FileNotFoundError):
        run_experiment("straight", tmp_path / "missing.yaml", tmp_path)
