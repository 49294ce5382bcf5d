"""``planner``: a privileged reference that knows the capsule layout and its own true state, to show how much of a
tier's failure is unavoidable. It flies through the same action interface and inner controller as every agent.

At an episode's first step it builds a cost-to-go table over the whole course by dynamic programming: stages
one agent step apart along x (the drone holds its forward speed), and per stage a grid over lateral position,
lateral velocity and the last lateral command. The lateral flight is a linear model of the closed loop (the
velocity controller with its attitude lag) fitted on an empty field; a stage costs a collision where the drone's
hull comes within ``hard_margin`` of a capsule or of the lateral bound, a growing penalty inside
``soft_clearance``, and a little for commanding and changing speed. Every step it then picks the command whose
one-step prediction from the true state (with a finer model) plus the table's cost-to-go is least: the table
plans, the true state closes the loop.

It reads the keys ``observe_layout=True`` adds (:mod:`flownav_env.privileged`), so it is declared privileged
(:data:`~agents.policies.base.PRIVILEGED_AGENTS`): a reference, never ranked.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import sparse

# What the planner needs the env to observe is its entry's ``env`` in configs/agents.yaml (observe_layout).
# The privileged keys it reads (flownav_env.privileged), the layout first.
PLANNER_KEYS = ("layout", "layout_mask", "true_state", "course")

# The lateral closed loop at 10 agent steps per second, fitted by least squares on 300 steps of random
# piecewise-constant commands over an empty field at 1 and 2 m/s (the two agreed to 0.01). u is the
# commanded world lateral velocity (m/s) of a step, u_prev the last step's: the attitude loop delays a command
# by about a step, so the last command carries most of the next velocity change.
MODEL_FRAME_RATE_HZ = 10.0
# For the table: vy' = a·vy + b·u + c·u_prev (rms 0.03 m/s per step).
PLAN_MODEL = (0.758, 0.071, 0.184)
# For the step: vy' = a·vy + b·vy_prev + c·u + d·u_prev (rms 0.007 m/s per step).
STEP_MODEL = (1.110, -0.318, 0.074, 0.126)
# y' = y + p·vy + q·vy' (m, velocities in m/s; rms 0.001 m).
POSITION_MODEL = (0.0483, 0.0524)
COLLISION_COST = 1e3
# Stage costs are read on a y grid this fine (m) and looked up nearest: edges blur by at most half of it.
FINE_Y_STEP_M = 0.02
# Only capsules this close along x (m, beyond their radius) can touch a stage.
NEAR_X_M = 1.0


def capsule_clearance(x: float, y: np.ndarray, capsules: np.ndarray) -> np.ndarray:
    """Horizontal distance (m) from points (x, ``y``) to the nearest capsule surface; inf without one near.

    ``capsules`` is (N, 3): x, y of the axis and radius (m).
    """
    y = np.asarray(y, np.float64)
    near = capsules[np.abs(capsules[:, 0] - x) <= capsules[:, 2] + NEAR_X_M]
    if len(near) == 0:
        return np.full(y.shape, math.inf)
    distance = np.hypot(x - near[:, 0], y[..., None] - near[:, 1]) - near[:, 2]
    return distance.min(axis=-1)


def stage_cost(
    clearance: np.ndarray,
    y: np.ndarray,
    *,
    drone_radius: float,
    lateral_bound: float,
    hard_margin: float,
    soft_clearance: float,
    clearance_weight: float,
) -> np.ndarray:
    """The cost of being at lateral positions ``y`` with capsule ``clearance`` (m) at one stage: a collision
    within ``hard_margin`` of a capsule or of the bound (the hull's ``drone_radius`` included), else
    ``clearance_weight`` times the squared share of ``soft_clearance`` still missing."""
    free = np.minimum(clearance, lateral_bound - np.abs(y)) - drone_radius - hard_margin
    shortfall = np.clip(1.0 - free / soft_clearance, 0.0, 1.0)
    return np.where(free < 0.0, COLLISION_COST, clearance_weight * shortfall**2)


@dataclass(frozen=True)
class PlanGrid:
    """The table's axes: lateral positions ``y`` (m), lateral velocities ``vy`` (m/s), commands ``u`` (m/s)."""

    y: np.ndarray
    vy: np.ndarray
    u: np.ndarray

    @property
    def shape(self) -> tuple[int, int, int]:
        """(last commands, positions, velocities): one stage of the table."""
        return len(self.u), len(self.y), len(self.vy)


def plan_grid(
    lateral_bound: float, max_lateral_speed: float, y_step: float, vy_levels: int, commands: int
) -> PlanGrid:
    """Positions across the bounds every ``y_step``; velocities over ±1.2 of the largest (the loop overshoots a
    little); ``commands`` evenly spread commands over ± ``max_lateral_speed``."""
    cells = math.ceil(lateral_bound / y_step)
    return PlanGrid(
        y=np.arange(-cells, cells + 1) * y_step,
        vy=np.linspace(-1.2, 1.2, vy_levels) * max_lateral_speed,
        u=np.linspace(-1.0, 1.0, commands) * max_lateral_speed,
    )


def command_cost(
    u: np.ndarray | float, u_prev: np.ndarray | float, control_weight: float, change_weight: float
) -> np.ndarray | float:
    """What commanding ``u`` after ``u_prev`` costs (m/s in, per stage): arrays broadcast, one command is a
    float."""
    return control_weight * u**2 + change_weight * (u - u_prev) ** 2


class CostToGoSweep:
    """The backward step of the cost-to-go over ``grid`` with stages ``stage_dx`` apart, its transition
    (where each (y, vy, last command, command) lands on the grid, and what the command costs) worked out once,
    so a table can be filled whole (:func:`build_cost_to_go`) or refilled over the stages a changed set of
    capsules reaches (the camera-limited planners, :mod:`agents.policies.planner_camera`).
    """

    def __init__(self, grid: PlanGrid, stage_dx: float, control_weight: float, change_weight: float) -> None:
        self.grid = grid
        self.stage_dx = stage_dx
        n_u, n_y, n_vy = grid.shape
        a, b, c = PLAN_MODEL
        p, q = POSITION_MODEL
        # Axes of one stage's choices: (y, vy, u_prev, u).
        y0 = grid.y[:, None, None, None]
        vy0 = grid.vy[None, :, None, None]
        u_prev, u = grid.u[None, None, :, None], grid.u[None, None, None, :]
        vy1 = a * vy0 + b * u + c * u_prev
        y1 = y0 + p * vy0 + q * vy1
        y1, vy1 = np.broadcast_arrays(y1, vy1)
        iy, wy = _cell(grid.y, y1)
        ivy, wvy = _cell(grid.vy, vy1)
        command = np.broadcast_to(np.arange(n_u)[None, None, None, :], y1.shape)
        base = command * n_y * n_vy
        corners = [
            (base + iy * n_vy + ivy, (1 - wy) * (1 - wvy)),
            (base + (iy + 1) * n_vy + ivy, wy * (1 - wvy)),
            (base + iy * n_vy + ivy + 1, (1 - wy) * wvy),
            (base + (iy + 1) * n_vy + ivy + 1, wy * wvy),
        ]
        # The bilinear read of the next stage as one sparse matrix, a row per choice (command first) holding its
        # four corners in this order: the sum runs in the same order as corner by corner, to the same bits,
        # about three times faster.
        choices = int(np.prod(y1.shape))
        self.interpolation = sparse.csr_matrix(
            (
                np.stack([_command_first(weight).reshape(-1) for _, weight in corners], axis=1).reshape(-1),
                np.stack([_command_first(index).reshape(-1) for index, _ in corners], axis=1).reshape(-1),
                np.arange(0, 4 * choices + 1, 4),
            ),
            shape=(choices, n_u * n_y * n_vy),
        )
        self.fine_y = np.arange(grid.y[0], grid.y[-1] + FINE_Y_STEP_M / 2, FINE_Y_STEP_M)
        self.fine_index = _command_first(
            np.clip(np.rint((y1 - self.fine_y[0]) / FINE_Y_STEP_M).astype(np.int64), 0, len(self.fine_y) - 1)
        )
        # Leaving the grid is leaving the bounds.
        off_grid = np.where((y1 < grid.y[0]) | (y1 > grid.y[-1]), COLLISION_COST, 0.0)
        self.fixed = _command_first(command_cost(u, u_prev, control_weight, change_weight) + off_grid)

    def stages(self, goal_x: float) -> int:
        """How many stages reach from x = 0 to the goal line ``goal_x`` (the last one at or past it)."""
        return math.ceil(goal_x / self.stage_dx) + 1

    def stage_of(self, x: float) -> int:
        """The stage nearest to ``x`` (m; not clamped to the table)."""
        return round(x / self.stage_dx)

    def fill(
        self, table: np.ndarray, capsules: np.ndarray, cost_of: dict[str, float], first: int, last: int
    ) -> None:
        """Recompute ``table``'s stages ``last`` down to ``first`` (both included, clamped to the table but its
        final stage) from the stage after ``last``, among ``capsules`` (N, 3) with :func:`stage_cost`'s
        keyword arguments ``cost_of``."""
        for k in range(min(last, len(table) - 2), max(first, 0) - 1, -1):
            x_next = (k + 1) * self.stage_dx
            fine_cost = stage_cost(capsule_clearance(x_next, self.fine_y, capsules), self.fine_y, **cost_of)
            ahead = self.interpolation @ table[k + 1].reshape(-1).astype(np.float64)
            choices = self.fixed + fine_cost[self.fine_index] + ahead.reshape(self.fixed.shape)
            # Cap so one collision's cost never grows by summing over stages (interpolation stays bounded).
            table[k] = np.minimum(choices.min(axis=0), COLLISION_COST).transpose(2, 0, 1)


def _command_first(values: np.ndarray) -> np.ndarray:
    """(y, vy, last command, command) choices laid out command first, so the best command is a minimum over
    contiguous blocks (several times faster than over a short last axis)."""
    return np.ascontiguousarray(np.moveaxis(np.broadcast_to(values, values.shape), -1, 0))


def build_cost_to_go(
    capsules: np.ndarray,
    goal_x: float,
    stage_dx: float,
    grid: PlanGrid,
    cost_of: dict[str, float],
    control_weight: float,
    change_weight: float,
) -> np.ndarray:
    """The cost-to-go (stages, last command, y, vy) from stage k at x = k·``stage_dx`` to the goal line.

    ``cost_of`` holds :func:`stage_cost`'s keyword arguments. A state between grid points reads the table
    bilinearly in (y, vy); the last command is always a grid command.
    """
    sweep = CostToGoSweep(grid, stage_dx, control_weight, change_weight)
    table = np.zeros((sweep.stages(goal_x), *grid.shape), np.float32)
    sweep.fill(table, capsules, cost_of, 0, len(table) - 2)
    return table


def _cell(axis: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The grid cell (lower index) holding each value and its weight toward the upper point, clamped to the axis."""
    step = axis[1] - axis[0]
    position = np.clip((values - axis[0]) / step, 0.0, len(axis) - 1 - 1e-9)
    index = np.floor(position).astype(np.int64)
    return index, position - index


def table_value(table_stage: np.ndarray, grid: PlanGrid, command: int, y: float, vy: float) -> float:
    """The cost-to-go of one stage's table at (last command index ``command``, ``y``, ``vy``), bilinearly."""
    iy, wy = _cell(grid.y, np.asarray(y))
    ivy, wvy = _cell(grid.vy, np.asarray(vy))
    square = table_stage[command, iy : iy + 2, ivy : ivy + 2]
    return float(
        square[0, 0] * (1 - wy) * (1 - wvy)
        + square[1, 0] * wy * (1 - wvy)
        + square[0, 1] * (1 - wy) * wvy
        + square[1, 1] * wy * wvy
    )


def step_prediction(
    y: float, vy: float, vy_prev: float, u: np.ndarray, u_prev: float
) -> tuple[np.ndarray, np.ndarray]:
    """Lateral position and velocity one step ahead under each command ``u`` (the finer :data:`STEP_MODEL`)."""
    a, b, c, d = STEP_MODEL
    p, q = POSITION_MODEL
    vy1 = a * vy + b * vy_prev + c * u + d * u_prev
    return y + p * vy + q * vy1, vy1


@dataclass
class PlannerAgent:
    """The privileged planner (module docstring). Its fields are its parameters; the table and the last step's
    velocity and command are per-episode state held on the object, rebuilt at ``episode_start``.

    The defaults were chosen on validation layouts (:data:`agents.common.seeds.PLANNER_TUNING_SEED_START`).
    """

    hard_margin: float = 0.08
    soft_clearance: float = 0.4
    clearance_weight: float = 2.0
    control_weight: float = 0.01
    change_weight: float = 0.05
    y_step: float = 0.1
    vy_levels: int = 15
    commands: int = 9
    height_gain: float = 1.5
    yaw_gain: float = 3.0

    def __post_init__(self) -> None:
        for name in ("hard_margin", "soft_clearance", "y_step"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)!r}")
        if self.commands < 3 or self.commands % 2 == 0:
            raise ValueError(f"commands must be an odd integer >= 3 (0 among them), got {self.commands!r}")
        self._table: np.ndarray | None = None
        self._grid: PlanGrid | None = None
        self._stage_dx = 0.0
        self._sweep: CostToGoSweep | None = None
        self._sweep_key: tuple[float, float, float] | None = None
        self._capsules = np.zeros((0, 3))
        self._command = self.commands // 2
        self._vy_prev = 0.0
        self._height = 0.0

    def predict(
        self,
        observation: dict[str, np.ndarray],
        state: object = None,
        episode_start: np.ndarray | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, object]:
        layout, mask, true, course = _unbatched(observation)
        starting = episode_start is not None and bool(np.asarray(episode_start).reshape(-1)[0])
        if starting or self._table is None:
            self._plan(layout, mask, true, course)
        action = self._act(true, course)
        return action, state

    def _cost_terms(self, course: np.ndarray) -> dict[str, float]:
        return {
            "drone_radius": float(course[7]),
            "lateral_bound": float(course[1]),
            "hard_margin": self.hard_margin,
            "soft_clearance": self.soft_clearance,
            "clearance_weight": self.clearance_weight,
        }

    def _start(self, true: np.ndarray, course: np.ndarray) -> CostToGoSweep:
        """Begin an episode on ``course``: the grid and the sweep over it (kept while the course's bound, lateral
        speed and stage length stay those of the last episode), no command yet, the height to hold."""
        lateral_bound, forward_speed, max_lateral = (float(course[i]) for i in (1, 3, 4))
        frame_rate = float(course[8])
        if not math.isclose(frame_rate, MODEL_FRAME_RATE_HZ):
            raise ValueError(
                f"the planner's flight model was fitted at frame_rate={MODEL_FRAME_RATE_HZ:g} Hz, got {frame_rate:g}"
            )
        if forward_speed <= 0.0:
            raise ValueError(f"the planner plans along x and needs forward_speed > 0, got {forward_speed:g}")
        self._stage_dx = forward_speed / frame_rate
        key = (lateral_bound, max_lateral, self._stage_dx)
        if self._sweep is None or self._sweep_key != key:
            self._grid = plan_grid(lateral_bound, max_lateral, self.y_step, self.vy_levels, self.commands)
            self._sweep = CostToGoSweep(self._grid, self._stage_dx, self.control_weight, self.change_weight)
            self._sweep_key = key
        self._command = self.commands // 2
        self._vy_prev = float(true[4])
        self._height = float(true[2])
        return self._sweep

    def _plan(self, layout: np.ndarray, mask: np.ndarray, true: np.ndarray, course: np.ndarray) -> None:
        sweep = self._start(true, course)
        self._capsules = np.asarray(layout, np.float64)[np.asarray(mask) > 0.5]
        self._table = np.zeros((sweep.stages(float(course[0])), *sweep.grid.shape), np.float32)
        sweep.fill(self._table, self._capsules, self._cost_terms(course), 0, len(self._table) - 2)

    def _act(self, true: np.ndarray, course: np.ndarray) -> np.ndarray:
        assert self._table is not None and self._grid is not None
        grid, table = self._grid, self._table
        x, y, z, vx, vy, yaw = (float(true[i]) for i in (0, 1, 2, 3, 4, 8))
        u_prev = float(grid.u[self._command])
        y1, vy1 = step_prediction(y, vy, self._vy_prev, grid.u, u_prev)
        x1 = x + vx / float(course[8])
        stage = int(np.clip(round(x1 / self._stage_dx), 0, len(table) - 1))
        here = stage_cost(capsule_clearance(x1, y1, self._capsules), y1, **self._cost_terms(course))
        totals = [
            here[i]
            + command_cost(grid.u[i], u_prev, self.control_weight, self.change_weight)
            + table_value(table[stage], grid, i, y1[i], vy1[i])
            for i in range(len(grid.u))
        ]
        self._command = int(np.argmin(totals))
        self._vy_prev = vy
        max_lateral, max_vertical, max_yaw_rate = (float(course[i]) for i in (4, 5, 6))
        lateral = -grid.u[self._command] / max_lateral  # action 0 > 0 steers right, toward -y
        vertical = self.height_gain * (self._height - z) / max_vertical
        # Yaw rate is -action 2 · max_yaw_rate: turning the heading back to +x.
        turn = self.yaw_gain * math.atan2(math.sin(yaw), math.cos(yaw)) / max_yaw_rate
        return np.clip(np.array([lateral, vertical, turn], np.float32), -1.0, 1.0)


def _unbatched(observation: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The privileged keys of one env's observation that the planner reads (a batch of one is unwrapped).

    Raises:
        ValueError: a key is missing (the env lacks ``observe_layout=True``), or a batch of more than one env.
    """
    layout, mask, true, course = unbatched_keys(observation, PLANNER_KEYS, "the planner")
    return layout, mask, true, course


def unbatched_keys(
    observation: dict[str, np.ndarray], keys: tuple[str, ...], reader: str
) -> list[np.ndarray]:
    """The values of ``keys`` in one env's observation as float64 arrays (a batch of one is unwrapped), for the
    agent ``reader`` (named in errors).

    Raises:
        ValueError: a key is missing (the env lacks ``observe_layout=True``), or a batch of more than one env.
    """
    missing = [key for key in keys if key not in observation]
    if missing:
        raise ValueError(f"{reader} reads {', '.join(missing)}: make the env with observe_layout=True")
    values = [np.asarray(observation[key], np.float64) for key in keys]
    # The layout (capsules, columns) is 2-D in one env's observation: a third axis is a batch.
    if values[0].ndim == 3:
        if values[0].shape[0] != 1:
            raise ValueError(f"{reader} flies one env at a time, got a batch of {values[0].shape[0]}")
        values = [value[0] for value in values]
    return values
