"""Quadrotor parameters and its inner cascaded controller (velocity → attitude → rotor thrusts).

The agent commands velocities; this controller turns them into the four rotor thrusts MuJoCo applies. The
body really tilts to accelerate (thrust is along body z), so the camera rotation that the estimator has to
compensate comes from the flight itself. The controller is a geometric SO(3) attitude controller (Lee et
al., 2010) under a proportional velocity loop, with the rotor allocation solved once as a 4×4 linear map.

Everything here is pure numpy on small arrays: no MuJoCo types, so it is testable on its own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

GRAVITY = 9.81


@dataclass(frozen=True)
class QuadrotorParams:
    """A ~1 kg X-configuration quadrotor (the size class of MuJoCo Menagerie's Skydio X2)."""

    mass: float = 1.0  # kg
    inertia: tuple[float, float, float] = (0.0075, 0.0075, 0.013)  # kg·m², body axes
    arm_length: float = 0.17  # m, centre to rotor
    max_rotor_thrust: float = 7.0  # N per rotor (thrust-to-weight ≈ 2.9)
    yaw_torque_per_thrust: float = 0.016  # N·m of reaction torque per N of thrust
    collision_radius: float = 0.2  # m, half-width of the hull used for contacts
    drag_coefficient: float = 0.35  # N per m/s of linear air drag
    camera_offset: str = "0.12 0 0"  # camera position in the body frame (m)
    # Front-left, front-right, back-right, back-left; body x forward, y left.
    rotor_signs_xy: tuple[tuple[int, int], ...] = ((1, 1), (1, -1), (-1, -1), (-1, 1))
    rotor_spin: tuple[int, ...] = (1, -1, 1, -1)


@dataclass(frozen=True)
class ControllerGains:
    """Gains of the cascade; attitude gains are natural frequencies, so they do not depend on inertia."""

    velocity: tuple[float, float, float] = (2.5, 2.5, 3.0)  # 1/s
    max_tilt_rad: float = np.deg2rad(30.0)
    max_vertical_acceleration: float = 4.0  # m/s²
    attitude_frequency: float = 18.0  # rad/s
    attitude_damping: float = 0.9
    yaw_frequency: float = 6.0  # rad/s


def allocation_matrix(params: QuadrotorParams) -> np.ndarray:
    """Map from the four rotor thrusts to (total thrust, roll, pitch, yaw torque) in the body frame."""
    arm = params.arm_length / np.sqrt(2.0)
    xs = np.array([sx * arm for sx, _ in params.rotor_signs_xy])
    ys = np.array([sy * arm for _, sy in params.rotor_signs_xy])
    spin = np.asarray(params.rotor_spin, np.float64)
    return np.vstack([np.ones(4), ys, -xs, spin * params.yaw_torque_per_thrust])


@dataclass
class VelocityController:
    """Cascaded velocity → attitude → thrust controller.

    Call it once per physics step with the measured state and the velocity command; it returns the four
    rotor thrusts (N), clipped to what the rotors can give.
    """

    params: QuadrotorParams = field(default_factory=QuadrotorParams)
    gains: ControllerGains = field(default_factory=ControllerGains)

    def __post_init__(self) -> None:
        mixer = np.linalg.inv(allocation_matrix(self.params))
        inertia = np.asarray(self.params.inertia)
        omega, zeta = self.gains.attitude_frequency, self.gains.attitude_damping
        k_rotation = inertia * np.array([omega**2, omega**2, self.gains.yaw_frequency**2])
        k_rate = inertia * 2 * zeta * np.array([omega, omega, self.gains.yaw_frequency])
        # Plain Python floats: the controller runs at every physics step, where numpy's per-call overhead on
        # 3-vectors costs more than the arithmetic (and more than MuJoCo's own step).
        self._mixer = tuple(tuple(float(value) for value in row) for row in mixer)
        self._k_rotation = tuple(float(value) for value in k_rotation)
        self._k_rate = tuple(float(value) for value in k_rate)
        self._k_velocity = tuple(float(value) for value in self.gains.velocity)
        self._max_horizontal = float(GRAVITY * np.tan(self.gains.max_tilt_rad))
        self._drag_per_mass = self.params.drag_coefficient / self.params.mass

    def __call__(
        self,
        rotation: np.ndarray,
        velocity_world: np.ndarray,
        angular_velocity_body: np.ndarray,
        velocity_target_world: np.ndarray,
        yaw_rate_target: float,
    ) -> np.ndarray:
        """Rotor thrusts for one physics step.

        Args:
            rotation: (3, 3) world-from-body rotation.
            velocity_world: (3,) linear velocity in the world frame, m/s.
            angular_velocity_body: (3,) angular velocity in the body frame, rad/s.
            velocity_target_world: (3,) commanded velocity, world frame, m/s.
            yaw_rate_target: commanded yaw rate, rad/s.

        Returns:
            (4,) rotor thrusts in N.
        """
        return np.array(
            self.thrusts(
                np.asarray(rotation, np.float64).reshape(9).tolist(),
                np.asarray(velocity_world, np.float64).tolist(),
                np.asarray(angular_velocity_body, np.float64).tolist(),
                np.asarray(velocity_target_world, np.float64).tolist(),
                float(yaw_rate_target),
            )
        )

    def thrusts(
        self,
        rotation: list[float],
        velocity_world: list[float],
        angular_velocity_body: list[float],
        velocity_target_world: list[float],
        yaw_rate_target: float,
    ) -> tuple[float, float, float, float]:
        """:meth:`__call__` on plain floats: ``rotation`` row-major (9 values, MuJoCo's ``xmat``), vectors
        as 3 values; returns the four thrusts. The physics loop calls this form."""
        kvx, kvy, kvz = self._k_velocity
        drag_per_mass = self._drag_per_mass
        vx, vy, vz = velocity_world
        tx, ty, tz = velocity_target_world
        ax = kvx * (tx - vx) + drag_per_mass * tx
        ay = kvy * (ty - vy) + drag_per_mass * ty
        horizontal = math.hypot(ax, ay)
        if horizontal > self._max_horizontal:
            ax *= self._max_horizontal / horizontal
            ay *= self._max_horizontal / horizontal
        limit = self.gains.max_vertical_acceleration
        az = min(max(kvz * (tz - vz) + drag_per_mass * tz, -limit), limit) + GRAVITY

        # Desired body z along the acceleration, keeping the current heading (yaw is rate-controlled).
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = rotation
        norm = math.sqrt(ax * ax + ay * ay + az * az)
        zx, zy, zz = ax / norm, ay / norm, az / norm
        yaw = math.atan2(r10, r00)
        hx, hy = math.cos(yaw), math.sin(yaw)
        yx, yy, yz = -zz * hy, zz * hx, zx * hy - zy * hx  # z_desired × heading
        norm = math.sqrt(yx * yx + yy * yy + yz * yz)
        yx, yy, yz = yx / norm, yy / norm, yz / norm
        xx, xy, xz = yy * zz - yz * zy, yz * zx - yx * zz, yx * zy - yy * zx  # y_desired × z_desired

        # Geometric attitude error e_R = ½ vee(R_dᵀR − RᵀR_d), then a PD law per body axis. Only the six
        # off-diagonal entries of R_dᵀR are needed: (R_dᵀR)[i, j] = (column i of R_d) · (column j of R).
        ex = 0.5 * ((zx * r01 + zy * r11 + zz * r21) - (yx * r02 + yy * r12 + yz * r22))
        ey = 0.5 * ((xx * r02 + xy * r12 + xz * r22) - (zx * r00 + zy * r10 + zz * r20))
        ez = 0.5 * ((yx * r00 + yy * r10 + yz * r20) - (xx * r01 + xy * r11 + xz * r21))
        wx, wy, wz = angular_velocity_body
        kr, kw = self._k_rotation, self._k_rate
        wrench = (
            self.params.mass * (ax * r02 + ay * r12 + az * r22),
            -kr[0] * ex - kw[0] * wx,
            -kr[1] * ey - kw[1] * wy,
            -kr[2] * ez - kw[2] * (wz - yaw_rate_target),
        )
        top = self.params.max_rotor_thrust
        t0, t1, t2, t3 = (
            min(max(m0 * wrench[0] + m1 * wrench[1] + m2 * wrench[2] + m3 * wrench[3], 0.0), top)
            for m0, m1, m2, m3 in self._mixer
        )
        return t0, t1, t2, t3


def velocity_command(
    yaw: float, action: np.ndarray, forward_speed: float, max_lateral_speed: float, max_vertical_speed: float
) -> np.ndarray:
    """World-frame velocity command of an action in [-1, 1]^3: ``forward_speed`` along the heading ``yaw``,
    sideways (positive to the right) and vertical (positive up) scaled by their largest speeds."""
    forward = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    left = np.array([-math.sin(yaw), math.cos(yaw), 0.0])
    return (
        forward_speed * forward
        - action[0] * max_lateral_speed * left
        + np.array([0.0, 0.0, action[1] * max_vertical_speed])
    )
