"""The thesis experiments' camera paths: scripted (straight, rotations, translations, random 6-DoF) or flown in
FlowNavEnv (the three-capsule flight)."""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import TypedDict

import numpy as np

from agents.studies.thesis.experiment_configs import (
    ExperimentConfig,
    ObstacleConfig,
    Random6DofConfig,
    RotationCase,
    RotationConfig,
    SceneConfig,
    StraightConfig,
    ThreeCapsuleConfig,
    TranslationConfig,
)
from flownav_env import FlowNavEnv
from flownav_env.playback import CameraPath, path_from_poses, record_env_flight
from flownav_env.rotations import camera_rotation, rotation_from_vector


class SceneArguments(TypedDict):
    """The scene of a camera path (:func:`flownav_env.playback.path_from_poses`' keywords): the capsules' (x, y)
    and materials, and the seed of their textures."""

    obstacles: np.ndarray
    materials: np.ndarray
    texture_seed: int


def scene_kwargs(
    config: ExperimentConfig, obstacles: Iterable[ObstacleConfig] | None = None
) -> SceneArguments:
    obstacles = list(config.obstacles if obstacles is None else obstacles)
    return {
        "obstacles": np.array([[o.x, o.y] for o in obstacles], np.float64).reshape(-1, 2),
        "materials": np.array([o.material for o in obstacles], np.int64),
        "texture_seed": config.texture_seed,
    }


def _vector3(name: str, values: list[float]) -> np.ndarray:
    array = np.asarray(values, np.float64)
    if array.shape != (3,) or not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be three finite numbers [x, y, z] in metres, got {values!r}")
    return array


def straight_path(config: StraightConfig) -> CameraPath:
    """Experiment 1's path: level camera looking along +x, moving ``distance_per_frame`` along +x per frame."""

    start = _vector3("start", config.start)
    steps = np.arange(config.frames)[:, None] * config.distance_per_frame
    positions = start + steps * np.array([1.0, 0.0, 0.0])
    rotations = np.repeat(camera_rotation(0.0)[None], config.frames, axis=0)
    return path_from_poses(rotations, positions, 10.0, **scene_kwargs(config))


def rotation_path(config: RotationConfig, case: RotationCase) -> CameraPath:
    """Experiment 2's path for one case: a fixed camera centre turning by the case's rotation each frame."""

    position = _vector3("position", config.position)
    rate = np.deg2rad([case.pitch_deg, case.yaw_deg, case.roll_deg])
    rotations = np.array(
        [camera_rotation(0.0, rotation_from_vector(k * rate)) for k in range(config.frames_per_case)]
    )
    positions = np.repeat(position[None], config.frames_per_case, axis=0)
    return path_from_poses(rotations, positions, 10.0, **scene_kwargs(config))


def translation_path(config: TranslationConfig, scene: SceneConfig) -> tuple[CameraPath, int]:
    """Experiment 3's path: along the camera's x axis, then its y axis; returns (path, index of the turn)."""

    start = _vector3("start", config.start)
    rotation = camera_rotation(0.0)
    x_steps = np.linspace(0.0, config.x_distance, config.frames_x + 1)
    y_steps = np.linspace(0.0, config.y_distance, config.frames_y + 1)[1:]
    corner = start + rotation[:, 0] * config.x_distance
    positions = np.concatenate(
        [start + x_steps[:, None] * rotation[:, 0], corner + y_steps[:, None] * rotation[:, 1]]
    )
    rotations = np.repeat(rotation[None], len(positions), axis=0)
    return path_from_poses(
        rotations, positions, 10.0, **scene_kwargs(config, scene.obstacles)
    ), config.frames_x


def random_6dof_path(config: Random6DofConfig) -> CameraPath:
    """Experiment 4's path: forward drift plus, per axis, a sum of three random sinusoids (human-like sway);
    the config's periods are checked on load (:meth:`Random6DofConfig.validate`)."""
    rng = np.random.default_rng(config.path_seed)
    frames = np.arange(config.frames)

    def sway(amplitude: float) -> np.ndarray:
        periods = rng.uniform(config.min_period_frames, config.max_period_frames, 3)
        phases = rng.uniform(0.0, 2 * np.pi, 3)
        weights = rng.dirichlet(np.ones(3))
        # Starting every sinusoid from its value at frame 0 keeps the first pose at the start.
        waves = np.sin(2 * np.pi * frames[:, None] / periods + phases) - np.sin(phases)
        return amplitude * waves @ weights

    start = _vector3("start", config.start)
    offsets = np.column_stack(
        [
            frames * config.forward_per_frame + sway(config.position_amplitude_m) * 0.3,
            sway(config.position_amplitude_m),
            sway(config.position_amplitude_m),
        ]
    )
    angles = np.deg2rad(np.column_stack([sway(config.rotation_amplitude_deg) for _ in range(3)]))
    rotations = np.array([camera_rotation(0.0, rotation_from_vector(a)) for a in angles])
    return path_from_poses(rotations, start + offsets, 30.0, **scene_kwargs(config))


def record_three_capsule_flight(config: ThreeCapsuleConfig) -> CameraPath:
    """Experiment 5's base path: FlowNavEnv's ``three`` layout flown under a scripted sinusoidal policy."""
    record = config.record
    env = FlowNavEnv(
        layout="three",
        forward_speed=record.forward_speed,
        frame_rate=record.frame_rate,
        camera_width=32,
        camera_height=24,
        texture_seed=config.texture_seed,
    )

    def policy(_observation: object, step: int) -> np.ndarray:
        phase = 2 * np.pi * step / record.period_steps
        return np.array(
            [
                record.lateral_action * math.sin(phase),
                record.vertical_action * math.sin(0.7 * phase),
                record.yaw_action * math.sin(0.5 * phase),
            ]
        )

    try:
        return record_env_flight(
            env, policy, record.steps, seed=record.env_seed, texture_seed=config.texture_seed
        )
    finally:
        env.close()
