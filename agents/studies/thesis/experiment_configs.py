"""The thesis experiments' configs (``configs/thesis/<name>.yaml``) as typed dataclasses, validated on load."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from agents.common.yaml_config import checked_field, field_range
from agents.studies.thesis.attitude import unity_to_camera_deg
from estimator import CameraIntrinsics, FlowDepthEstimator
from flownav_env.playback import DISTANCE_PER_FRAME
from flownav_env.settings_check import setting_check


@dataclass
class ObstacleConfig:
    """A capsule standing on the ground at (x, y) with a material index (see ``scene.material_names``)."""

    x: float = field_range(-100.0, 100.0, default=5.0)
    y: float = field_range(-100.0, 100.0, default=0.0)
    material: int = field_range(0, 5, default=0)


@dataclass
class CameraConfig:
    """Camera resolution and vertical field of view."""

    width: int = checked_field(setting_check("camera_width"), default=640)
    height: int = checked_field(setting_check("camera_height"), default=480)
    fov_deg: float = checked_field(setting_check("camera_fov_deg"), default=60.0)


def _one_capsule() -> list[ObstacleConfig]:
    return [ObstacleConfig(5.0, 0.0, 0)]


@dataclass
class ExperimentConfig:
    """Fields every experiment shares.

    Attributes:
        camera: Resolution and field of view.
        estimator: Keyword arguments of :class:`estimator.FlowDepthEstimator` other than ``method`` (both
            methods run).
        texture_seed: Seed of the procedural textures.
        seed: Seed of the playback's random numbers.
        obstacles: The capsules.
    """

    camera: CameraConfig = field(default_factory=CameraConfig)
    estimator: dict[str, Any] = field(default_factory=dict)
    texture_seed: int = field_range(0, None, default=0)
    seed: int = field_range(0, None, default=0)
    obstacles: list[ObstacleConfig] = field(default_factory=_one_capsule)

    def validate(self) -> None:
        """Check the estimator kwargs by building an estimator; raises ValueError naming the bad key."""
        if "method" in self.estimator:
            raise ValueError("key 'estimator.method' is not allowed: every experiment runs both methods")
        intrinsics = CameraIntrinsics.from_fov(self.camera.width, self.camera.height, self.camera.fov_deg)
        try:
            FlowDepthEstimator(intrinsics, **self.estimator)
        except TypeError as error:
            raise ValueError(f"key 'estimator': {error}") from error
        except ValueError as error:
            raise ValueError(f"key 'estimator.{str(error).split(' ', 1)[0]}': {error}") from error


@dataclass
class StraightConfig(ExperimentConfig):
    """Experiment 1: straight flight along the optical axis (world +x) toward the capsule."""

    start: list[float] = field(default_factory=lambda: [0.0, 0.0, 1.0])
    distance_per_frame: float = field_range(0.001, 1.0, default=0.05)
    frames: int = field_range(3, 10000, default=60)


@dataclass
class ThesisRotationCase:
    """A row of the thesis's Table 2: its Unity angles and what it measured (one frame pair, f = 417 px)."""

    test: int = field_range(1, 100, default=1)
    unity_deg: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])  # rot x, y, z in Unity
    mean_px: float = field_range(0.0, None, default=0.0)
    mean_inliers_px: float | None = field_range(0.0, None, default=None)  # None: every point an outlier
    points: int = field_range(0, None, default=0)
    points_inliers: int = field_range(0, None, default=0)


@dataclass
class RotationCase:
    """One pure rotation of Table 2: a constant rotation per frame about the camera's own axes (degrees)."""

    name: str = "case"
    pitch_deg: float = field_range(-30.0, 30.0, default=0.0)  # about the camera's x axis (right); + looks up
    yaw_deg: float = field_range(-30.0, 30.0, default=0.0)  # about the camera's y axis (down); + looks right
    roll_deg: float = field_range(-30.0, 30.0, default=0.0)  # about the optical axis; + right side down
    thesis: ThesisRotationCase | None = None


@dataclass
class RotationConfig(ExperimentConfig):
    """Experiment 2: pure rotations about the camera centre (Table 2)."""

    position: list[float] = field(default_factory=lambda: [1.0, 0.0, 1.0])
    frames_per_case: int = field_range(2, 1000, default=8)
    outlier_px: float = field_range(0.0, None, default=5.0)
    cases: list[RotationCase] = field(default_factory=lambda: [RotationCase("yaw 2 deg", yaw_deg=2.0)])

    def validate(self) -> None:
        """As :meth:`ExperimentConfig.validate`, plus: a case quoting a thesis row flies that row's angles."""
        super().validate()
        for index, case in enumerate(self.cases):
            if case.thesis is None:
                continue
            if len(case.thesis.unity_deg) != 3:
                raise ValueError(f"key 'cases[{index}].thesis.unity_deg' must be three angles [x, y, z]")
            expected = unity_to_camera_deg(case.thesis.unity_deg)
            flown = (case.pitch_deg, case.yaw_deg, case.roll_deg)
            if any(abs(a - b) > 1e-9 for a, b in zip(flown, expected, strict=True)):
                raise ValueError(
                    f"key 'cases[{index}]': Unity angles {case.thesis.unity_deg} are (pitch, yaw, roll) = "
                    f"{expected} in FlowNav (pitch = -x, yaw = y, roll = -z), but the case flies {flown}"
                )


@dataclass
class SceneConfig:
    """A named set of capsules."""

    name: str = "scene"
    obstacles: list[ObstacleConfig] = field(default_factory=_one_capsule)


@dataclass
class TranslationConfig(ExperimentConfig):
    """Experiment 3: translation along the camera's x axis, then along its y axis, past each scene."""

    scenes: list[SceneConfig] = field(default_factory=lambda: [SceneConfig("one capsule")])
    start: list[float] = field(default_factory=lambda: [1.0, 1.5, 1.0])
    x_distance: float = field_range(-20.0, 20.0, default=3.0)  # along camera x (right), m
    y_distance: float = field_range(-5.0, 5.0, default=-0.6)  # along camera y (down; negative = up), m
    frames_x: int = field_range(1, 10000, default=40)
    frames_y: int = field_range(1, 10000, default=20)


@dataclass
class Random6DofConfig(ExperimentConfig):
    """Experiment 4: a smooth random 6-DoF path (sums of random sinusoids) drifting toward the capsule."""

    start: list[float] = field(default_factory=lambda: [0.0, 0.0, 1.0])
    frames: int = field_range(3, 10000, default=80)
    forward_per_frame: float = field_range(0.0, 1.0, default=0.03)
    position_amplitude_m: float = field_range(0.0, 2.0, default=0.3)
    rotation_amplitude_deg: float = field_range(0.0, 30.0, default=4.0)
    min_period_frames: float = field_range(4.0, None, default=20.0)
    max_period_frames: float = field_range(4.0, None, default=80.0)
    path_seed: int = field_range(0, None, default=0)

    def validate(self) -> None:
        """As :meth:`ExperimentConfig.validate`, plus ``min_period_frames <= max_period_frames``."""
        super().validate()
        if self.min_period_frames > self.max_period_frames:
            raise ValueError(
                f"key 'min_period_frames' must be <= max_period_frames ({self.max_period_frames}), "
                f"got {self.min_period_frames}"
            )


@dataclass
class RecordConfig:
    """The base flight of experiment 5, recorded from FlowNavEnv under a scripted sinusoidal policy."""

    env_seed: int = field_range(0, None, default=0)
    steps: int = field_range(2, 10000, default=40)
    forward_speed: float = checked_field(setting_check("forward_speed"), default=1.0)
    frame_rate: float = checked_field(setting_check("frame_rate"), default=10.0)
    lateral_action: float = field_range(0.0, 1.0, default=0.3)
    vertical_action: float = field_range(0.0, 1.0, default=0.2)
    yaw_action: float = field_range(0.0, 1.0, default=0.3)
    period_steps: float = field_range(2.0, None, default=20.0)


@dataclass
class BaseSettingsConfig:
    """The base run's test variables; each sweep changes one of them."""

    distance_per_frame: float = checked_field(DISTANCE_PER_FRAME.check, default=0.05)
    brightness: float = checked_field(setting_check("brightness"), default=1.0)
    attitude_jitter_deg: float = checked_field(setting_check("attitude_jitter_deg"), default=0.0)
    rotation_error: float = checked_field(setting_check("rotation_error"), default=0.0)
    translation_error: float = checked_field(setting_check("translation_error"), default=0.0)
    max_frames: int = field_range(2, 10000, default=40)


@dataclass
class SweepConfig:
    """Values of each test variable (Appendices C–H); the others stay at the base run's values."""

    attitude_jitter_deg: list[float] = checked_field(
        setting_check("attitude_jitter_deg"), default_factory=lambda: [0.0, 1.0, 2.5]
    )
    distance_per_frame: list[float] = checked_field(
        DISTANCE_PER_FRAME.check, default_factory=lambda: [0.005, 0.05, 0.3]
    )
    brightness: list[float] = checked_field(
        setting_check("brightness"), default_factory=lambda: [0.5, 1.0, 2.0]
    )
    rotation_error: list[float] = checked_field(
        setting_check("rotation_error"), default_factory=lambda: [0.0, 0.1]
    )
    translation_error: list[float] = checked_field(
        setting_check("translation_error"), default_factory=lambda: [0.0, 0.1]
    )
    # Not a playback setting: the rotation error applied to the absolute attitude (agents.studies.thesis.attitude).
    attitude_rotation_error: list[float] = checked_field(
        setting_check("rotation_error"), default_factory=lambda: [0.0, 0.1]
    )


@dataclass
class ThreeCapsuleConfig(ExperimentConfig):
    """Experiment 5: the three-capsule scene; the capsules come from the env's ``three`` layout."""

    record: RecordConfig = field(default_factory=RecordConfig)
    base: BaseSettingsConfig = field(default_factory=BaseSettingsConfig)
    sweeps: SweepConfig = field(default_factory=SweepConfig)
    obstacles: list[ObstacleConfig] = field(default_factory=list)
    # The thesis ran its rotation-error tests on its 0.5 deg instability run, not on the plain base run.
    rotation_error_jitter_deg: float = checked_field(setting_check("attitude_jitter_deg"), default=0.5)
