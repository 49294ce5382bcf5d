"""Camera-limited planners: privileged references that plan like ``planner`` but know only the capsules the
camera has seen, to tell what the camera's view allows from what the whole map allows.

``planner_camera`` (:class:`CameraPlannerAgent`) knows a capsule once some pixel column's ray from the camera's
true pose hits it first within ``view_range`` (:mod:`agents.policies.camera_view`: the env's horizontal field of
view, about 75° at 160 × 120 px with its 60° vertical one; nearer capsules hide farther ones), at its exact
position. With ``memory`` it keeps every capsule it has seen; without, only those in view now.

``planner_camera_observed`` (:class:`ObservedCameraPlannerAgent`) knows each seen capsule only as the
observation's histogram resolves it: its front point at the centre of its sector column and of its depth bin
(the env's ``histogram_sectors`` and ``depth_bin_edges``). With ``memory`` it keeps, for a capsule out of view,
where it was resolved when last seen whole (its front point inside the image), else where last seen at all.

Both know the true state and the course's bounds, and treat what they have not seen as free. They plan with the
planner's cost-to-go (:class:`~agents.policies.planner.CostToGoSweep`): at an episode's start the table of an
empty field (built once per course and kept), and whenever the known capsules change, the stages those
capsules reach are refilled from the farthest down to the drone. They read the keys ``observe_layout=True`` adds
(:mod:`flownav_env.privileged`), so they are declared privileged
(:data:`~agents.policies.base.PRIVILEGED_AGENTS`): references, never ranked.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from agents.policies.camera_view import column_rays, resolved_capsules, seen_capsules
from agents.policies.planner import NEAR_X_M, PLANNER_KEYS, PlannerAgent, unbatched_keys

# The privileged keys they read, the layout first (flownav_env.privileged).
CAMERA_PLANNER_KEYS = (*PLANNER_KEYS, "camera", "depth_bin_edges")
# Indices into the env's ``camera`` key (flownav_env.privileged.CAMERA_FIELDS).
_POSITION, _ROTATION, _FX, _CX, _WIDTH = slice(0, 3), slice(3, 12), 12, 13, 14
# A frame's view as the histogram functions of agents.policies.camera_view take it, after the capsules: camera
# position, rotation, fx, cx, width (px), sector columns and depth bin edges.
View = tuple[np.ndarray, np.ndarray, float, float, int, int, np.ndarray]


def histogram_view(camera: np.ndarray, columns: int, edges: np.ndarray) -> View:
    """The env's ``camera`` key and the histogram's sector ``columns`` and bin ``edges`` as a :data:`View`."""
    return (
        camera[_POSITION],
        camera[_ROTATION].reshape(3, 3),
        float(camera[_FX]),
        float(camera[_CX]),
        round(float(camera[_WIDTH])),
        columns,
        edges,
    )


@dataclass
class CameraPlannerAgent(PlannerAgent):
    """``planner_camera`` (module docstring): the planner's parameters, and how far the camera sees capsules
    (``view_range``, m) and whether it remembers those that left the view (``memory``)."""

    view_range: float = 2.0
    memory: bool = True

    def __post_init__(self) -> None:
        super().__post_init__()
        if isinstance(self.view_range, bool) or not (
            isinstance(self.view_range, int | float)
            and math.isfinite(self.view_range)
            and self.view_range > 0.0
        ):
            raise ValueError(f"view_range must be a finite distance > 0 (m), got {self.view_range!r}")
        if not isinstance(self.memory, bool | np.bool_):
            raise ValueError(f"memory must be True or False, got {self.memory!r}")
        # Capsule (its row in the layout) -> what is known of it (x, y, radius), and whether it was seen whole.
        self._known: dict[int, np.ndarray] = {}
        self._whole: dict[int, bool] = {}
        self._planned: dict[int, np.ndarray] = {}
        self._empty_key: tuple[float, ...] | None = None
        self._empty_table: np.ndarray | None = None
        self.replans = 0

    @property
    def known_capsules(self) -> dict[int, np.ndarray]:
        """What it knows this episode: each capsule's row in the layout → (x, y, radius) as it knows them (m)."""
        return {row: capsule.copy() for row, capsule in self._known.items()}

    @property
    def seen_whole(self) -> dict[int, bool]:
        """Per known capsule, whether what it knows comes from a view with the capsule's front point inside the
        image (always, for the exact planner)."""
        return dict(self._whole)

    @property
    def reader(self) -> str:
        """The agent's name, for errors."""
        return "planner_camera"

    @property
    def keys(self) -> tuple[str, ...]:
        """The observation keys it reads."""
        return CAMERA_PLANNER_KEYS

    def predict(
        self,
        observation: dict[str, np.ndarray],
        state: object = None,
        episode_start: np.ndarray | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, object]:
        values = unbatched_keys(observation, self.keys, self.reader)
        layout, mask, true, course, camera, edges = values[:6]
        starting = episode_start is not None and bool(np.asarray(episode_start).reshape(-1)[0])
        if starting or self._table is None:
            self._start_episode(true, course)
        columns = values[6].shape[1] if len(values) > 6 else 0  # the histogram's (rows, columns, bins)
        self._see(layout[mask > 0.5], camera, edges, columns)
        self._replan(float(true[0]), course)
        return self._act(true, course), state

    def _start_episode(self, true: np.ndarray, course: np.ndarray) -> None:
        """The empty field's table (built once per course, copied per episode), nothing known yet."""
        sweep = self._start(true, course)
        key = (*(float(value) for value in course[[0, 1, 7]]), *(self._sweep_key or ()))
        if self._empty_table is None or self._empty_key != key:
            self._empty_table = np.zeros((sweep.stages(float(course[0])), *sweep.grid.shape), np.float32)
            sweep.fill(
                self._empty_table, np.zeros((0, 3)), self._cost_terms(course), 0, len(self._empty_table)
            )
            self._empty_key = key
        self._table = self._empty_table.copy()
        self._known, self._whole, self._planned = {}, {}, {}
        self._capsules = np.zeros((0, 3))
        self.replans = 0

    def _see(self, capsules: np.ndarray, camera: np.ndarray, edges: np.ndarray, columns: int) -> None:
        """Update what is known from this frame: the capsules in view now, as :meth:`_estimates` knows them."""
        position, rotation = camera[_POSITION], camera[_ROTATION].reshape(3, 3)
        # Only a capsule whose surface comes within the range can be hit: the rays need test no other.
        near = np.flatnonzero(
            np.hypot(*(capsules[:, :2] - position[:2]).T) - capsules[:, 2] <= self.view_range
        )
        rays = column_rays(rotation, camera[_FX], camera[_CX], round(float(camera[_WIDTH])))
        rows = near[seen_capsules(position[:2], rays, capsules[near], self.view_range)]
        estimates, whole = self._estimates(rows, capsules[rows], camera, edges, columns)
        if not self.memory:
            self._known, self._whole = {}, {}
        for row, estimate, is_whole in zip(rows.tolist(), estimates, whole.tolist(), strict=True):
            # Memory keeps a capsule's last whole view over a later one at the image's edge.
            if is_whole or not self._whole.get(row, False):
                self._known[row], self._whole[row] = estimate, is_whole

    def _estimates(
        self, rows: np.ndarray, capsules: np.ndarray, camera: np.ndarray, edges: np.ndarray, columns: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """What is known of the ``capsules`` in view (their ``rows`` in the layout name them from frame to frame):
        their exact rows, each seen whole."""
        return capsules, np.ones(len(capsules), bool)

    def _replan(self, x: float, course: np.ndarray) -> None:
        """Refill the table over the stages the capsules that changed since the last plan reach, from the
        farthest down to the drone's ``x``."""
        changed = [
            capsule
            for rows, other in ((self._known, self._planned), (self._planned, self._known))
            for row, capsule in rows.items()
            if row not in other or not np.array_equal(other[row], capsule)
        ]
        if not changed:
            return
        assert self._table is not None and self._sweep is not None
        reach = max(float(capsule[0] + capsule[2]) for capsule in changed) + NEAR_X_M
        self._capsules = np.array([self._known[row] for row in sorted(self._known)]).reshape(-1, 3)
        first = self._sweep.stage_of(x) - 1
        last = math.ceil(reach / self._sweep.stage_dx)
        self._sweep.fill(self._table, self._capsules, self._cost_terms(course), first, last)
        self._planned = dict(self._known)
        self.replans += 1


@dataclass
class ObservedCameraPlannerAgent(CameraPlannerAgent):
    """``planner_camera_observed`` (module docstring): :class:`CameraPlannerAgent` knowing each capsule in view
    where the observation's histogram resolves it."""

    @property
    def reader(self) -> str:
        return "planner_camera_observed"

    @property
    def keys(self) -> tuple[str, ...]:
        # The histogram's shape gives its sector columns.
        return (*CAMERA_PLANNER_KEYS, "depth_histogram")

    def _estimates(
        self, rows: np.ndarray, capsules: np.ndarray, camera: np.ndarray, edges: np.ndarray, columns: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """The ``capsules`` in view as the histogram resolves them, and which were seen whole."""
        return resolved_capsules(capsules, *histogram_view(camera, columns, edges))
