"""``planner_camera_filtered``: the observation-limited reference integrated over frames, what the histogram allows
an agent that remembers and reasons with the told motion.

:class:`~agents.policies.planner_camera.ObservedCameraPlannerAgent` puts a seen capsule at the centre of the
histogram cell its front point falls in, frame by frame. This planner keeps, for each capsule, the positions of
its centre that every frame's cell allows: at its first sighting a grid of candidates spread over the cell (its
sector's columns, its bin's depths), then at each later frame with the capsule's front point inside the image
only the candidates whose own front point falls in the cell the capsule was observed in. It plans on their mean.
Where no candidate is left (a cell's edge between two frames' grids), it starts again from the current cell. Seen
from a moving camera, a cell cuts the candidates along other lines each frame, so the mean closes in on the
capsule as it is approached: what a filter over frames with the known motion could recover from the histogram
alone (the drone's true pose stands in for the told motion; a privileged reference, never ranked).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from agents.policies.camera_view import (
    cell_points,
    centres_behind,
    front_points,
    histogram_cells,
)
from agents.policies.planner_camera import ObservedCameraPlannerAgent, View, histogram_view


@dataclass
class FilteredCameraPlannerAgent(ObservedCameraPlannerAgent):
    """``planner_camera_filtered`` (module docstring): the observed planner's parameters, and how many candidates
    span a cell along each of its two sides (``grid``; ``grid`` ² per capsule)."""

    grid: int = 9

    def __post_init__(self) -> None:
        super().__post_init__()
        if isinstance(self.grid, bool) or not isinstance(self.grid, int) or not 2 <= self.grid <= 64:
            raise ValueError(f"grid must be an integer in [2, 64], got {self.grid!r}")
        # Capsule (its row in the layout) -> the candidate centres (K, 2) every frame's cell allows so far.
        self._candidates: dict[int, np.ndarray] = {}

    @property
    def reader(self) -> str:
        return "planner_camera_filtered"

    def _start_episode(self, true: np.ndarray, course: np.ndarray) -> None:
        super()._start_episode(true, course)
        self._candidates = {}

    def _estimates(
        self, rows: np.ndarray, capsules: np.ndarray, camera: np.ndarray, edges: np.ndarray, columns: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """Each capsule in view at the mean of the centres that every frame's cell allows, and whether its front
        point lay inside the image now (a frame that clamps it to the edge sector narrows nothing)."""
        view = histogram_view(camera, columns, edges)
        capsules = np.asarray(capsules, np.float64).reshape(-1, 3)
        sector, bins, inside = histogram_cells(front_points(capsules, view[0]), *view)
        estimates = np.empty_like(capsules)
        for index, row in enumerate(np.asarray(rows).tolist()):
            cell = (int(sector[index]), int(bins[index]))
            radius = float(capsules[index, 2])
            known = self._candidates.get(row)
            if known is None or (
                inside[index] and not (kept := self._in_cell(known, radius, cell, view)).any()
            ):
                known = self._cell_candidates(cell, radius, view)
            elif inside[index]:
                known = known[kept]
            self._candidates[row] = known
            estimates[index] = (*known.mean(axis=0), radius)
        return estimates, inside

    def _cell_candidates(self, cell: tuple[int, int], radius: float, view: View) -> np.ndarray:
        """Centres (grid², 2) whose front points spread over ``cell`` (sector, bin) as seen from ``view``."""
        fractions = (np.arange(self.grid) + 0.5) / self.grid
        across, deep = (axis.reshape(-1) for axis in np.meshgrid(fractions, fractions))
        count = len(across)
        front = cell_points(np.full(count, cell[0]), np.full(count, cell[1]), *view, across, deep)
        return centres_behind(front, np.full(count, radius), view[0])

    @staticmethod
    def _in_cell(candidates: np.ndarray, radius: float, cell: tuple[int, int], view: View) -> np.ndarray:
        """Which candidate centres put the capsule's front point in ``cell`` (sector, bin) as seen from ``view``."""
        circles = np.column_stack([candidates, np.full(len(candidates), radius)])
        sector, bins, inside = histogram_cells(front_points(circles, view[0]), *view)
        return inside & (sector == cell[0]) & (bins == cell[1])
