"""MuJoCo physics of the FlowNav world with named accessors (dm_control style) instead of raw indices.

Owns the ``MjModel``/``MjData`` pair, the quadrotor's inner controller, the obstacle pool and the forward
camera's mount. Knows nothing of rewards, observations or the estimator: what is asked of the drone in this
world is the task's (:mod:`flownav_env.task`).
"""

from __future__ import annotations

import mujoco
import numpy as np

from flownav_env.camera_convention import opencv_camera_pose
from flownav_env.quadrotor import ControllerGains, QuadrotorParams, VelocityController
from flownav_env.scene import (
    PARKED_GROUP,
    PARKED_Z,
    LayoutParams,
    build_scene_xml,
    material_names,
    paint_textures,
    set_camera_near_plane,
)


def _quat_from_matrix(rotation: np.ndarray) -> np.ndarray:
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(rotation, np.float64).reshape(9))
    return quat


class FlowNavPhysics:
    """The simulated world: a quadrotor with a forward camera among capsule obstacles."""

    def __init__(
        self,
        layout: LayoutParams,
        quad: QuadrotorParams,
        gains: ControllerGains,
        *,
        timestep: float,
        camera_fov_deg: float,
        offscreen_size: tuple[int, int],
        texture_seed: int,
    ) -> None:
        self.layout = layout
        self.quad = quad
        xml = build_scene_xml(
            layout, quad, timestep=timestep, camera_fov_deg=camera_fov_deg, offscreen_size=offscreen_size
        )
        self.model = mujoco.MjModel.from_xml_string(xml)
        set_camera_near_plane(self.model)
        paint_textures(self.model, texture_seed)
        self.data = mujoco.MjData(self.model)
        self.controller = VelocityController(quad, gains)

        def object_id(kind: mujoco.mjtObj, name: str) -> int:
            return mujoco.mj_name2id(self.model, kind, name)

        self.drone_body = object_id(mujoco.mjtObj.mjOBJ_BODY, "drone")
        self.camera_id = object_id(mujoco.mjtObj.mjOBJ_CAMERA, "front")
        self.obstacle_geoms = np.array(
            [object_id(mujoco.mjtObj.mjOBJ_GEOM, f"obstacle{i}") for i in range(layout.max_obstacles)]
        )
        self.material_ids = np.array(
            [object_id(mujoco.mjtObj.mjOBJ_MATERIAL, name) for name in material_names()]
        )
        self.sun_light = object_id(mujoco.mjtObj.mjOBJ_LIGHT, "sun")
        self._camera_mount_quat = self.model.cam_quat[self.camera_id].copy()
        self._camera_mount_rotation = np.empty(9)
        mujoco.mju_quat2Mat(self._camera_mount_rotation, self._camera_mount_quat)
        self._base_light = (
            self.model.light_diffuse[self.sun_light].copy(),
            self.model.vis.headlight.ambient.copy(),
            self.model.vis.headlight.diffuse.copy(),
        )
        self.obstacle_positions = np.zeros((0, 2))
        self._drone_geoms = np.flatnonzero(self.model.geom_bodyid == self.drone_body)

    # --- world set-up -------------------------------------------------------------------------------------------
    def place_obstacles(self, positions: np.ndarray, materials: np.ndarray) -> None:
        """Stand capsules at ``positions`` (N, 2) with material indices ``materials`` (N,); park the rest.

        Positions go to the mocap bodies' defaults in the model too, so ``mj_resetData`` keeps them.
        """
        count = len(positions)
        geoms = self.obstacle_geoms
        bodies = self.model.geom_bodyid[geoms]
        self.model.body_pos[bodies] = (0.0, 0.0, PARKED_Z)
        self.model.geom_group[geoms] = PARKED_GROUP
        if count:
            self.model.body_pos[bodies[:count], :2] = positions
            self.model.body_pos[bodies[:count], 2] = self.layout.obstacle_height / 2.0
            self.model.geom_matid[geoms[:count]] = self.material_ids[materials]
            self.model.geom_group[geoms[:count]] = 0
        self.data.mocap_pos[self.model.body_mocapid[bodies]] = self.model.body_pos[bodies]
        self.obstacle_positions = np.asarray(positions, np.float64).reshape(-1, 2)

    def set_brightness(self, brightness: float) -> None:
        """Scale the sun and the headlight: 1 is the default daylight, 0 is darkness."""
        sun, ambient, diffuse = self._base_light
        self.model.light_diffuse[self.sun_light] = sun * brightness
        self.model.vis.headlight.ambient = ambient * brightness
        self.model.vis.headlight.diffuse = diffuse * brightness

    def reset_drone(self, position: np.ndarray, yaw: float, velocity_world: np.ndarray) -> None:
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[:3] = position
        self.data.qpos[3:7] = (np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2))
        self.data.qvel[:3] = velocity_world
        # Start in hover so the first step has no thrust transient.
        self.data.ctrl[:] = self.quad.mass * 9.81 / 4
        mujoco.mj_forward(self.model, self.data)

    # --- stepping -----------------------------------------------------------------------------------------------
    def advance(
        self,
        velocity_target_world: np.ndarray,
        yaw_rate: float,
        substeps: int,
        camera_disturbance: np.ndarray | None = None,
    ) -> bool:
        """Fly ``substeps`` physics steps under the velocity controller; stop early on contact.

        Args:
            velocity_target_world: (3,) commanded velocity, m/s.
            yaw_rate: commanded yaw rate, rad/s.
            substeps: physics steps to take.
            camera_disturbance: the camera mount's rotation for the frame taken after this advance (see
                :meth:`set_camera_mount`); None keeps the current one.

        Returns:
            True if the drone touched an obstacle or the ground.
        """
        data, model = self.data, self.model
        drag = self.quad.drag_coefficient
        thrusts = self.controller.thrusts
        target = [float(value) for value in velocity_target_world]
        yaw_rate = float(yaw_rate)
        body_rotation = data.xmat[self.drone_body]
        body_force = data.xfrc_applied[self.drone_body]
        collided = False
        for _ in range(substeps):
            velocity = data.qvel[:6].tolist()
            data.ctrl[:] = thrusts(body_rotation.tolist(), velocity[:3], velocity[3:], target, yaw_rate)
            body_force[:3] = (-drag * velocity[0], -drag * velocity[1], -drag * velocity[2])
            mujoco.mj_step(model, data)
            if data.ncon and self.in_contact():
                collided = True
                break
        if camera_disturbance is not None:
            self._mount_camera(camera_disturbance)
        # mj_step leaves kinematics (and camera poses) from before its integration: refresh them, once.
        mujoco.mj_kinematics(model, data)
        mujoco.mj_camlight(model, data)
        return collided

    def in_contact(self) -> bool:
        contacts = self.data.contact
        if self.data.ncon == 0:
            return False
        geoms = np.concatenate([contacts.geom1[: self.data.ncon], contacts.geom2[: self.data.ncon]])
        return bool(np.isin(geoms, self._drone_geoms).any())

    def set_camera_mount(self, disturbance: np.ndarray) -> None:
        """Rotate the camera on its mount by ``disturbance`` (3, 3, in the mount's own axes) and refresh poses."""
        self._mount_camera(disturbance)
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)

    def _mount_camera(self, disturbance: np.ndarray) -> None:
        mount = self._camera_mount_rotation.reshape(3, 3) @ disturbance
        self.model.cam_quat[self.camera_id] = _quat_from_matrix(mount)

    # --- named state accessors ----------------------------------------------------------------------------------
    def position(self) -> np.ndarray:
        return self.data.qpos[:3].copy()

    def velocity_world(self) -> np.ndarray:
        return self.data.qvel[:3].copy()

    def rotation(self) -> np.ndarray:
        """World-from-body rotation (3, 3)."""
        return self.data.xmat[self.drone_body].reshape(3, 3).copy()

    def yaw(self) -> float:
        rotation = self.data.xmat[self.drone_body]
        return float(np.arctan2(rotation[3], rotation[0]))

    def roll_pitch(self) -> tuple[float, float]:
        r = self.data.xmat[self.drone_body]
        roll = np.arctan2(r[7], r[8])
        pitch = np.arcsin(np.clip(-r[6], -1.0, 1.0))
        return float(roll), float(pitch)

    def camera_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """World pose of the forward camera in OpenCV axes: (R world-from-camera, position)."""
        return opencv_camera_pose(self.data.cam_xmat[self.camera_id], self.data.cam_xpos[self.camera_id])

    def obstacle_clearance(self) -> float:
        """Distance from the drone's centre to the nearest capsule surface (m); inf without obstacles."""
        if len(self.obstacle_positions) == 0:
            return float("inf")
        position = self.data.qpos[:3]
        radius = self.layout.obstacle_radius
        # Nearest point on each capsule's vertical axis segment, then subtract the radius.
        axis_z = np.clip(position[2], radius, self.layout.obstacle_height - radius)
        horizontal = np.linalg.norm(self.obstacle_positions - position[:2], axis=1)
        return float(np.min(np.hypot(horizontal, position[2] - axis_z)) - radius)

    def ray_depths(self, rays_camera: np.ndarray, rotation: np.ndarray, position: np.ndarray) -> np.ndarray:
        """True z-depth along camera rays ``[x, y, 1]`` (N, 3, OpenCV axes) from a camera pose; NaN on a miss.

        Rays with unit z in the camera frame make MuJoCo's hit distance the z-depth itself.
        """
        count = len(rays_camera)
        if count == 0:
            return np.zeros(0)
        directions = np.ascontiguousarray((rays_camera @ rotation.T).reshape(-1), np.float64)
        distances = np.empty(count)
        hit_geoms = np.empty(count, np.int32)
        mujoco.mj_multiRay(
            self.model,
            self.data,
            np.asarray(position, np.float64),
            directions,
            None,
            True,
            self.drone_body,
            hit_geoms,
            distances,
            None,
            count,
            1e3,
        )
        return np.where(hit_geoms >= 0, distances, np.nan)
