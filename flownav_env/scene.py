"""The scene: MJCF for ground, sky, lights, a pool of capsule obstacles and the quadrotor; obstacle layouts.

The model is built once per environment with a fixed pool of ``max_obstacles`` capsules. A reset only moves
capsules (mocap bodies) and reassigns their materials, so no model is recompiled and no GL context is
rebuilt between episodes. Unused capsules are parked far below the ground, out of reach. (Their
collisions stay enabled: MuJoCo leaves geoms compiled without collisions out of its collision structures.)

Layouts are pure functions ``(rng, params) -> (positions (N, 2), goal_x)`` in world metres, x pointing from the
start toward the goal line and z up.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from flownav_env.quadrotor import QuadrotorParams
from flownav_env.textures import TEXTURE_GENERATORS, grass_texture

LAYOUTS = ("field", "corridor", "single", "three")

TEXTURE_SIZE = 256
MATERIALS_PER_KIND = 2
PARKED_Z = -50.0
# Parked capsules move to a geom group the renderers do not draw: drawn underground they cost render time.
PARKED_GROUP = 3
# The drone's own geoms and rotor sites: the onboard camera sits inside the hull and sees none of them, but a
# software rasteriser still transforms every triangle, so the onboard camera leaves this group out.
DRONE_GROUP = 2
# Capsule tessellation (slices around, stacks per cap). A software rasteriser pays per triangle, and MuJoCo's
# 28 x 16 made the capsules most of a frame's time; 16 x 8 keeps the silhouette within 1 cm of the true 0.5 m
# circle, which at the env's resolutions (offscreen buffers up to 320 px wide) left the estimator's depth error
# unchanged (results/throughput/README.md has the timings and errors). Wider frames resolve the facets (the thesis
# replication's capsule depth error at 640x480 grew with the coarse mesh), so they keep MuJoCo's mesh.
COARSE_MESH_MAX_WIDTH = 320
CAPSULE_MESH = {"coarse": (16, 8), "fine": (28, 16)}


def capsule_mesh(offscreen_width: int) -> tuple[int, int]:
    """(slices, stacks) of the capsules for an offscreen buffer ``offscreen_width`` pixels wide."""
    return CAPSULE_MESH["coarse" if offscreen_width <= COARSE_MESH_MAX_WIDTH else "fine"]


# The plane's third size is its rendering grid spacing; a fine grid multiplies the triangles the software
# rasteriser draws (0.1 m took half of each frame) for no visible difference under a directional sun.


@dataclass(frozen=True)
class LayoutParams:
    """Geometry of the obstacle course (metres)."""

    obstacle_radius: float = 0.5
    obstacle_height: float = 2.0
    obstacle_density: float = 0.12  # capsules per m² of the field's obstacle zone
    field_length: float = 20.0  # distance from the start to the goal line
    field_width: float = 8.0  # width of the band in which field capsules stand
    start_clearance: float = 3.0  # no capsule closer than this (along x) to the start
    min_gap: float = 0.8  # free space between neighbouring capsule surfaces in a field
    corridor_width: float = 2.5  # free width between the two rows of a corridor
    corridor_spacing: float = 1.3  # distance between capsule centres along a corridor row
    corridor_bend: float = 1.5  # largest sideways excursion of a bending corridor's centre line
    max_obstacles: int = 64


def capsule_half_length(params: LayoutParams) -> float:
    """MuJoCo's capsule size is (radius, half-length of the cylinder): total height = 2·(r + h)."""
    return params.obstacle_height / 2.0 - params.obstacle_radius


def field_layout(rng: np.random.Generator, params: LayoutParams) -> tuple[np.ndarray, float]:
    """Random capsules at ``obstacle_density`` in a band ahead of a clear start zone."""
    x_low, x_high = params.start_clearance, params.field_length - 1.0
    half_width = params.field_width / 2.0
    area = max(x_high - x_low, 0.0) * params.field_width
    target = min(round(params.obstacle_density * area), params.max_obstacles)
    min_distance = 2 * params.obstacle_radius + params.min_gap
    # Dart throwing: sampling is cheap, acceptance is inherently sequential but only over ~tens of capsules.
    candidates = np.column_stack(
        [rng.uniform(x_low, x_high, 20 * target + 1), rng.uniform(-half_width, half_width, 20 * target + 1)]
    )
    accepted: list[np.ndarray] = []
    for candidate in candidates:
        if len(accepted) == target:
            break
        if not accepted or np.min(np.linalg.norm(np.asarray(accepted) - candidate, axis=1)) >= min_distance:
            accepted.append(candidate)
    return np.asarray(accepted, np.float64).reshape(-1, 2), params.field_length


def corridor_centre(x: np.ndarray, amplitude: float, phase: float, period: float) -> np.ndarray:
    """Sideways offset of a bending corridor's centre line; zero at the start so the drone enters centred."""
    return amplitude * (np.sin(2 * np.pi * x / period + phase) - np.sin(phase))


def corridor_layout(rng: np.random.Generator, params: LayoutParams) -> tuple[np.ndarray, float]:
    """Two rows of capsules forming a passage that bends by up to ``corridor_bend`` metres."""
    xs = np.arange(1.0, params.field_length, params.corridor_spacing)
    amplitude = rng.uniform(0.0, params.corridor_bend)
    phase = rng.uniform(0, 2 * np.pi)
    period = rng.uniform(12.0, 24.0)
    centre = corridor_centre(xs, amplitude, phase, period)
    offset = params.corridor_width / 2.0 + params.obstacle_radius
    rows = [np.column_stack([xs, centre + side * offset]) for side in (-1.0, 1.0)]
    positions = np.concatenate(rows)[: params.max_obstacles]
    return positions, params.field_length


def single_layout(rng: np.random.Generator, params: LayoutParams) -> tuple[np.ndarray, float]:
    """One capsule straight ahead (thesis Fig. 14), slightly off-axis so avoidance has a preferred side."""
    return np.array([[5.0, rng.uniform(-0.25, 0.25)]]), 10.0


def three_layout(rng: np.random.Generator, params: LayoutParams) -> tuple[np.ndarray, float]:
    """Three capsules at different depths and sides (thesis Fig. 41), jittered per seed."""
    base = np.array([[4.0, -0.9], [6.5, 0.8], [9.0, -0.2]])
    return base + rng.uniform(-0.2, 0.2, base.shape), 12.0


LAYOUT_FUNCTIONS = {
    "field": field_layout,
    "corridor": corridor_layout,
    "single": single_layout,
    "three": three_layout,
}


def material_names() -> list[str]:
    return [f"{kind}{i}" for kind in TEXTURE_GENERATORS for i in range(MATERIALS_PER_KIND)]


# The cameras' near clipping plane, in metres. MuJoCo's <map znear> is a fraction of the model's extent, which
# the course makes about 60 m: the old fraction 0.02 clipped everything within 1.2 m of the camera, so near
# capsules rendered hollow and the flow agents flew blind exactly where collisions happen. The nearest surface
# the forward camera can face is the hull's radius minus the camera's offset, about 8 cm.
CAMERA_NEAR_M = 0.05


def set_camera_near_plane(model: mujoco.MjModel) -> None:
    """Put every camera's near clipping plane at :data:`CAMERA_NEAR_M`, whatever the model's extent."""
    model.vis.map.znear = CAMERA_NEAR_M / model.stat.extent


def build_scene_xml(
    params: LayoutParams,
    quad: QuadrotorParams,
    *,
    timestep: float,
    camera_fov_deg: float,
    offscreen_size: tuple[int, int],
) -> str:
    """MJCF of the whole world. Textures are placeholders here; :func:`paint_textures` fills them in."""
    half_length = capsule_half_length(params)
    textures = "\n".join(
        f'<texture name="tex_{name}" type="cube" builtin="flat" width="{TEXTURE_SIZE}" height="{TEXTURE_SIZE}" '
        f'rgb1="1 1 1"/>\n<material name="{name}" texture="tex_{name}" specular="0.1"/>'
        for name in material_names()
    )
    # Each capsule is a mocap body: static geoms share one bounding-volume tree fixed at compile time, so
    # moving them after compilation would hide them from collision detection; mocap bodies move freely.
    capsules = "\n".join(
        f'<body name="obstacle{i}" mocap="true" pos="0 0 {PARKED_Z}"><geom name="obstacle{i}" type="capsule" '
        f'size="{params.obstacle_radius} {half_length}" material="{material_names()[0]}"/></body>'
        for i in range(params.max_obstacles)
    )
    arm = quad.arm_length / np.sqrt(2.0)
    rotors = "\n".join(
        f'<site name="rotor{i}" pos="{sx * arm:.4f} {sy * arm:.4f} 0.02" size="0.06 0.005" type="cylinder" '
        f'rgba=".1 .1 .1 .6" group="{DRONE_GROUP}"/>'
        for i, (sx, sy) in enumerate(quad.rotor_signs_xy)
    )
    motors = "\n".join(
        f'<motor name="motor{i}" site="rotor{i}" gear="0 0 1 0 0 {spin * quad.yaw_torque_per_thrust:.5f}" '
        f'ctrllimited="true" ctrlrange="0 {quad.max_rotor_thrust}"/>'
        for i, spin in enumerate(quad.rotor_spin)
    )
    width, height = offscreen_size
    slices, stacks = capsule_mesh(width)
    return f"""
<mujoco model="flownav">
  <option timestep="{timestep}" integrator="implicitfast"/>
  <visual>
    <global offwidth="{width}" offheight="{height}"/>
    <quality offsamples="0" shadowsize="0" numslices="{slices}" numstacks="{stacks}"/>
    <headlight ambient="0.3 0.3 0.3" diffuse="0.3 0.3 0.3" specular="0 0 0"/>
    <map zfar="200"/>
  </visual>
  <asset>
    <texture name="sky" type="skybox" builtin="gradient" rgb1="0.55 0.7 0.9" rgb2="0.9 0.93 0.97"
             width="64" height="64"/>
    <texture name="tex_grass" type="2d" builtin="flat" width="{TEXTURE_SIZE}" height="{TEXTURE_SIZE}"
             rgb1="1 1 1"/>
    <material name="grass" texture="tex_grass" texrepeat="60 60" specular="0"/>
    {textures}
  </asset>
  <worldbody>
    <light name="sun" directional="true" pos="0 0 10" dir="-0.3 -0.2 -1" diffuse="0.7 0.7 0.7"
           specular="0.1 0.1 0.1" castshadow="false"/>
    <geom name="ground" type="plane" size="100 100 10" material="grass"/>
    {capsules}
    <body name="drone" pos="0 0 1">
      <freejoint name="drone"/>
      <inertial pos="0 0 0" mass="{quad.mass}" diaginertia="{quad.inertia[0]} {quad.inertia[1]} {quad.inertia[2]}"/>
      <geom name="drone_hull" type="ellipsoid" size="{quad.collision_radius} {quad.collision_radius} 0.05"
            rgba=".85 .3 .1 1" mass="0" group="{DRONE_GROUP}"/>
      {rotors}
      <camera name="front" pos="{quad.camera_offset}" fovy="{camera_fov_deg}" xyaxes="0 -1 0 0 0 1"/>
      <camera name="chase" mode="trackcom" pos="-2.5 0 1.2" xyaxes="0 -1 0 0.42 0 0.91" fovy="70"/>
      <camera name="top" mode="trackcom" pos="2 0 10" xyaxes="0 -1 0 1 0 0" fovy="70"/>
    </body>
  </worldbody>
  <actuator>
    {motors}
  </actuator>
</mujoco>
"""


def paint_textures(model: mujoco.MjModel, texture_seed: int) -> None:
    """Fill the placeholder textures of a compiled model with procedural patterns (in place).

    Args:
        model: the compiled ``mujoco.MjModel`` from :func:`build_scene_xml`.
        texture_seed: seed of the patterns; the same seed gives the same world look.
    """
    rng = np.random.default_rng(texture_seed)

    def write(name: str, rgb: np.ndarray) -> None:
        tex_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_TEXTURE, name)
        start = model.tex_adr[tex_id]
        size = model.tex_width[tex_id] * model.tex_height[tex_id] * model.tex_nchannel[tex_id]
        model.tex_data[start : start + size] = rgb.reshape(-1)[:size]

    write("tex_grass", grass_texture(rng, TEXTURE_SIZE))
    for kind, generate in TEXTURE_GENERATORS.items():
        for i in range(MATERIALS_PER_KIND):
            # A cube texture holds six square faces stacked vertically; each face gets its own pattern.
            faces = np.concatenate([generate(rng, TEXTURE_SIZE) for _ in range(6)])
            write(f"tex_{kind}{i}", faces)
