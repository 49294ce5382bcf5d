"""Helpers shared by several test modules: small env settings and a tiny training config.

Test modules import them as ``from helpers import ...``: pytest puts ``tests/`` on the import path because
``tests/conftest.py`` lives there, so this works under bare ``pytest`` as well as ``python -m pytest``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import yaml

from agents.common.yaml_config import load_config
from agents.evaluation.episode import EpisodeRecord
from agents.training.train_config import TrainConfig

# The real third-party images with ground truth, in ../shared beside the repository.
TESTDATA = Path(__file__).resolve().parents[2] / "shared" / "testdata"

SMALL = {"camera_width": 96, "camera_height": 72}


def tiny_train_config(
    directory: Path, total: int, name: str = "tiny_ppo", **keys
) -> tuple[TrainConfig, Path]:
    config_path = directory / f"{name}_config.yaml"
    content = {
        "name": name,
        "env_id": "FlowNavSingle-v0",
        "env": SMALL,
        "total_timesteps": total,
        "n_envs": 1,
        "checkpoint_every": 64,
        "eval_every": 64,
        "eval_episodes": 1,
        "ppo": {"n_steps": 64, "batch_size": 32, "n_epochs": 1, "net_arch": [16]},
        **keys,
    }
    config_path.write_text(yaml.safe_dump(content))
    return load_config(config_path, TrainConfig), config_path


def with_other_defaults(init, **defaults):
    """``init`` with other defaults for some keyword arguments: a re-tuned dataclass."""

    def patched(self, **kwargs):
        init(self, **{**defaults, **kwargs})

    return patched


# One flown episode's record, for tests of what reads and writes episodes.
EPISODE = EpisodeRecord(
    agent="straight",
    factor="clean",
    level=0.0,
    seed=1_000_000,
    collision=True,
    success=False,
    out_of_bounds=False,
    truncated=False,
    progress_m=3.87,
    time_s=3.9,
    steps=39,
    min_clearance_m=0.19,
    path_length_m=3.77,
    mean_points_valid=127.9,
    median_depth_error=0.046,
    episode_return=-6.125,
    env_id="FlowNavSingle-v0",
    env_kwargs='{"camera_height":72,"camera_width":96}',
    agent_params="{}",
    policy_sha256="",
    code_version="commit `abc1234`",
)


# The modules that fly: a simulator, the env, the estimator, images, learning.
FLIGHT_PACKAGES = ("mujoco", "gymnasium", "flownav_env", "estimator", "cv2", "torch", "stable_baselines3")


def flight_modules_loaded_by(module: str) -> list[str]:
    """The :data:`FLIGHT_PACKAGES` modules that importing ``module`` loads, in a fresh interpreter with this
    checkout's packages first on its path (as pytest's own path has them)."""
    code = (
        f"import json, sys; import {module}; "
        f"print(json.dumps(sorted(m for m in sys.modules if m.split('.')[0] in {FLIGHT_PACKAGES!r})))"
    )
    root = Path(__file__).resolve().parents[1]
    path = os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")])
    loaded = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "PYTHONPATH": path},
    )
    return list(json.loads(loaded.stdout))


def teacher_started_record(directory: Path, imitation: dict, **keys) -> tuple[TrainConfig, Path]:
    """Train a tiny run (64 steps, ``keys`` as in :func:`tiny_train_config`) that starts by imitating the teacher
    ``imitation`` names; the run's config and its training record's path."""
    from agents.policies.teachers import make_teacher
    from agents.training.outputs import RunFiles
    from agents.training.ppo import train

    config, config_path = tiny_train_config(directory, total=64, imitation=imitation, **keys)
    runs = directory / "runs"
    train(
        config,
        config_path=config_path,
        resume=False,
        runs_dir=runs,
        progress_bar=False,
        make_teacher=make_teacher,
    )
    return config, RunFiles.of(runs, config.name).record


def processes_with(marker: str) -> list[int]:
    """The ids of this machine's processes whose command line holds ``marker`` (its arguments joined by NULs)."""
    found = []
    for name in os.listdir("/proc"):
        try:
            if name.isdigit() and marker in Path(f"/proc/{name}/cmdline").read_bytes().decode(
                errors="replace"
            ):
                found.append(int(name))
        except OSError:
            continue
    return found


def fly_hard_camera_layout(agent, steps: int) -> list[tuple[dict, object]]:
    """``steps`` steps of ``agent`` (a camera-limited planner) on the hard tier's first camera-reference layout, at a
    small camera: each observation it acted on, with its action."""
    import gymnasium as gym

    import flownav_env  # noqa: F401  (registers the env ids)
    from agents.common.seeds import CAMERA_REFERENCE_SEED_START
    from flownav_env.tiers import TIERS

    hard = TIERS["hard"]
    env = gym.make(
        hard.env_id,
        **hard.settings,
        observe_layout=True,
        camera_width=64,
        camera_height=48,
        depth_error_info=False,
    )
    flown = []
    try:
        observation, _ = env.reset(seed=CAMERA_REFERENCE_SEED_START)
        start = [True]
        for _ in range(steps):
            action, _ = agent.predict(observation, episode_start=start)
            start = [False]
            flown.append((observation, action))
            observation, _, terminated, truncated, _ = env.step(action)
            assert not (terminated or truncated)
    finally:
        env.close()
    return flown
