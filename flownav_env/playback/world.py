"""The FlowNav scene with a kinematically placed camera, for playing recorded paths back (§3.5)."""

from __future__ import annotations

import mujoco
import numpy as np

from flownav_env.camera_convention import MUJOCO_FROM_OPENCV
from flownav_env.physics import FlowNavPhysics
from flownav_env.playback.path import CameraPath
from flownav_env.quadrotor import ControllerGains, QuadrotorParams
from flownav_env.rendering import CameraRenderer
from flownav_env.scene import LayoutParams, material_names
from flownav_env.settings_check import setting_range


class PlaybackWorld:
    """The FlowNav scene with a kinematically placed camera: renders and ray-casts a path's frames.

    The drone body is placed so that its forward camera has the requested pose (nothing is simulated), which
    makes playback exact and independent of the controller.

    Args:
        path: Supplies the scene (obstacles, materials, texture seed, capsule size).
        width: Image width in pixels, inside the env's ``camera_width`` range.
        height: Image height in pixels, inside the env's ``camera_height`` range.
        fov_deg: Vertical field of view in degrees, inside the env's ``camera_fov_deg`` range.

    Raises:
        ValueError: A size or the field of view is out of range.
    """

    def __init__(self, path: CameraPath, width: int, height: int, fov_deg: float = 60.0) -> None:
        # The env's camera limits, under playback's own argument names.
        width = setting_range("camera_width").check_int("width", width)
        height = setting_range("camera_height").check_int("height", height)
        self.fov_deg = setting_range("camera_fov_deg").check("fov_deg", fov_deg)
        materials = len(material_names())
        if len(path.materials) and (path.materials.min() < 0 or path.materials.max() >= materials):
            raise ValueError(f"materials must be in [0, {materials - 1}], got {path.materials.tolist()}")
        self.width, self.height = width, height
        self.layout = LayoutParams(
            obstacle_radius=path.obstacle_radius,
            obstacle_height=path.obstacle_height,
            max_obstacles=max(1, len(path.obstacles)),
        )
        self.physics = FlowNavPhysics(
            self.layout,
            QuadrotorParams(),
            ControllerGains(),
            timestep=0.004,
            camera_fov_deg=self.fov_deg,
            offscreen_size=(self.width, self.height),
            texture_seed=path.texture_seed,
        )
        self.physics.place_obstacles(path.obstacles, path.materials)
        self.physics.reset_drone(np.array([0.0, 0.0, 1.0]), 0.0, np.zeros(3))
        self.obstacles = path.obstacles.copy()
        self.renderer = CameraRenderer(self.physics.model, self.width, self.height, onboard=True)
        model, camera = self.physics.model, self.physics.camera_id
        mount = np.empty(9)
        mujoco.mju_quat2Mat(mount, model.cam_quat[camera])
        self._mount_rotation = mount.reshape(3, 3)
        self._mount_offset = model.cam_pos[camera].copy()

    def set_camera_pose(self, rotation: np.ndarray, position: np.ndarray) -> None:
        """Place the drone so that its camera has this world pose (OpenCV axes) and refresh the kinematics."""
        physics = self.physics
        camera_mujoco = np.asarray(rotation, np.float64) @ MUJOCO_FROM_OPENCV
        body_rotation = camera_mujoco @ self._mount_rotation.T
        body_position = np.asarray(position, np.float64) - body_rotation @ self._mount_offset
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, np.ascontiguousarray(body_rotation).reshape(9))
        physics.data.qpos[:3] = body_position
        physics.data.qpos[3:7] = quat
        physics.data.qvel[:] = 0.0
        mujoco.mj_kinematics(physics.model, physics.data)
        mujoco.mj_camlight(physics.model, physics.data)

    def camera_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """The camera's current world pose as MuJoCo computed it: (R world-from-camera, OpenCV axes; p)."""
        return self.physics.camera_pose()

    def set_brightness(self, brightness: float) -> None:
        """Scene light level (1 = daylight)."""
        self.physics.set_brightness(setting_range("brightness").check_float("brightness", brightness))

    def render(self) -> np.ndarray:
        """RGB frame (H, W, 3) uint8 from the current camera pose."""
        return self.renderer.render(self.physics.data, self.physics.camera_id)

    def true_depth(self, rays: np.ndarray, rotation: np.ndarray, position: np.ndarray) -> np.ndarray:
        """Exact z-depth along camera rays ``[x, y, 1]`` (N, 3) from a camera pose; NaN where nothing is hit."""
        return self.physics.ray_depths(np.asarray(rays, np.float64).reshape(-1, 3), rotation, position)

    def label_points(self, world_points: np.ndarray) -> np.ndarray:
        """Which surface each world point lies on: capsule index (>= 0), -1 ground, -2 nothing (NaN point)."""
        return label_world_points(
            world_points, self.obstacles, self.layout.obstacle_radius, self.layout.obstacle_height
        )

    def close(self) -> None:
        """Release the GL context."""
        self.renderer.close()


def label_world_points(
    world_points: np.ndarray, obstacles: np.ndarray, radius: float, height: float, tolerance: float = 0.02
) -> np.ndarray:
    """Label 3-D points by the surface they lie on: capsule index, -1 for the ground, -2 for NaN (sky).

    Args:
        world_points: (N, 3) points in the world, m (NaN rows for rays that hit nothing).
        obstacles: (M, 2) capsule centres (x, y), m; capsules stand on the ground.
        radius: Capsule radius, m.
        height: Capsule height, m.
        tolerance: Slack in metres on the capsule radius (ray-cast hits carry float rounding).

    Returns:
        (N,) int64 labels.
    """
    points = np.asarray(world_points, np.float64).reshape(-1, 3)
    labels = np.full(len(points), -1, np.int64)
    labels[~np.all(np.isfinite(points), axis=1)] = -2
    if len(obstacles):
        # Distance from each point to each capsule's axis segment (z from radius to height - radius).
        axis_z = np.clip(points[:, 2:3], radius, height - radius)
        horizontal = np.linalg.norm(points[:, None, :2] - np.asarray(obstacles)[None, :, :], axis=2)
        distance = np.hypot(horizontal, points[:, 2:3] - axis_z)
        nearest = np.argmin(distance, axis=1)
        on_capsule = np.take_along_axis(distance, nearest[:, None], axis=1)[:, 0] <= radius + tolerance
        on_capsule &= labels != -2
        labels[on_capsule] = nearest[on_capsule]
    return labels
