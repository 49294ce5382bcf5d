"""The quadrotor's cascaded controller: the per-step form on plain floats equals the array form, and it holds
a hover."""

from __future__ import annotations

import numpy as np

from flownav_env.quadrotor import GRAVITY, QuadrotorParams, VelocityController, velocity_command
from flownav_env.rotations import rotation_from_vector


def test_the_float_form_gives_the_array_forms_thrusts() -> None:
    controller = VelocityController()
    rng = np.random.default_rng(0)
    for _ in range(50):
        rotation = rotation_from_vector(rng.uniform(-0.4, 0.4, 3))
        velocity, rates, target = rng.normal(size=3), rng.normal(size=3), rng.normal(size=3)
        yaw_rate = float(rng.normal())
        thrusts = controller(rotation, velocity, rates, target, yaw_rate)
        floats = controller.thrusts(
            rotation.reshape(9).tolist(), velocity.tolist(), rates.tolist(), target.tolist(), yaw_rate
        )
        np.testing.assert_allclose(thrusts, floats, rtol=0, atol=1e-12)
        assert np.all((thrusts >= 0) & (thrusts <= QuadrotorParams().max_rotor_thrust))


def test_level_and_at_the_commanded_velocity_it_hovers() -> None:
    params = QuadrotorParams()
    thrusts = VelocityController(params)(np.eye(3), np.zeros(3), np.zeros(3), np.zeros(3), 0.0)
    np.testing.assert_allclose(thrusts, params.mass * GRAVITY / 4, rtol=1e-12)


def test_velocity_command_flies_forward_along_the_heading() -> None:
    command = velocity_command(np.pi / 2, np.array([1.0, -1.0, 0.0]), 2.0, 1.0, 0.5)
    # Heading +y: forward is +y; a positive lateral action slides right, which is +x; -1 vertical is down.
    np.testing.assert_allclose(command, [1.0, 2.0, -0.5], atol=1e-12)
