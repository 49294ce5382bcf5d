"""Hand-written reactive agents with stable-baselines3's ``predict`` interface, so one evaluation path scores
them all.

* ``straight``: flies straight at the flight height, no avoidance: the floor.
* ``bee``: reactive centring from the depth histogram, after honeybees in corridors (Srinivasan et al.,
  1996): balance the optic-flow nearness (inverse depth) seen on the left and on the right, and turn away
  from what looms ahead.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from agents.policies.view_bands import band_columns, band_mean
from estimator import DEFAULT_BIN_EDGES

# The bee's regions of the view: the left and the right SIDE_SHARE of the image's width, whose nearness it
# balances, and the middle between them, where it watches for looming. At the 5 columns it was tuned at they are
# the two outer columns each side and the middle one (15 degrees of the 75-degree view); a rule written in columns
# would watch a 5-degree band at 15 columns and balance 7 columns each side, which is not the law it was tuned as.
SIDE_SHARE = Fraction(2, 5)


def check_bins(histogram: np.ndarray, bin_edges: Sequence[float]) -> None:
    """Refuse a histogram (..., bins) whose bins are not those of the rule's ``bin_edges``: a rule must be given
    the env's ``depth_bin_edges``.

    Raises:
        ValueError: one line naming both counts.
    """
    if histogram.shape[-1] != len(bin_edges) - 1:
        raise ValueError(
            f"the depth histogram has {histogram.shape[-1]} bins but the rule's bin_edges {tuple(bin_edges)} make "
            f"{len(bin_edges) - 1}: give the rule the env's depth_bin_edges"
        )


def bin_nearness(bin_edges: np.ndarray) -> np.ndarray:
    """Representative nearness (1/m) of each depth bin: the inverse of its middle; the open last bin uses its
    lower edge doubled, since depths beyond the last edge are counted in it."""
    edges = np.asarray(bin_edges, np.float64)
    middles = 0.5 * (edges[:-1] + edges[1:])
    middles[-1] = 2.0 * edges[-2] if edges[-2] > 0 else edges[-1]
    return 1.0 / np.maximum(middles, 1e-3)


def sector_nearness(histogram: np.ndarray, bin_edges: np.ndarray) -> np.ndarray:
    """Mean nearness per sector (rows, cols) from a depth histogram (rows, cols, bins); 0 where a sector is empty.

    Histogram values are fractions of the sector's points per bin, so the weighted sum is the sector's mean
    nearness.
    """
    return np.asarray(histogram, np.float64) @ bin_nearness(bin_edges)


def heights_and_headings(observation: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray, bool]:
    state = np.asarray(observation["state"], np.float64)
    batched = state.ndim == 2
    state = state.reshape(-1, state.shape[-1])
    return state[:, 5], state[:, 6], batched


@dataclass
class StraightAgent:
    """Holds the flight height and the goal heading; never avoids anything."""

    flight_height: float = 1.0
    height_gain: float = 2.0
    heading_gain: float = 1.5

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        heights, headings, batched = heights_and_headings(observation)
        actions = np.zeros((len(heights), 3), np.float32)
        actions[:, 1] = np.clip(self.height_gain * (self.flight_height - heights), -1, 1)
        # Heading error is positive to the left; a positive yaw action turns right.
        actions[:, 2] = np.clip(self.heading_gain * headings, -1, 1)
        return (actions if batched else actions[0]), state


@dataclass
class BeeAgent:
    """Bee-style centring on the depth histogram.

    ``lateral = centring_gain · (nearness_left − nearness_right) + frontal_gain · looming · side``: the drone
    slides away from the nearer side, and when the centre looms (its nearness exceeds ``frontal_threshold``) it
    also turns and slides toward the emptier side. Only the sector rows at and above the horizon are used: the
    bottom row mostly sees the ground. The sides and the centre are shares of the view, not columns
    (:data:`SIDE_SHARE`), so the law reads the same angles at any ``histogram_sectors`` column count. Height
    and heading are held as in :class:`StraightAgent`. The gains are the winner of ``flownav tune --agent bee`` (40 TPE trials on 30
    training layouts, 5 finalists on 150 fresh training layouts; ``results/tuning/bee/tuning.md``, re-tuned
    2026-12-02 after the camera's near-plane fix), to 4 significant digits: failure 0.17 [0.12, 0.24] on the
    final layouts, against 0.29 [0.22, 0.36] with the gains of the 16-candidate search before the fix
    (0.595, 3.959, 0.257, 0.033; ``results/bee_tuning/``). The intervals overlap: the best measured, not
    clearly better.
    """

    bin_edges: tuple[float, ...] = tuple(DEFAULT_BIN_EDGES)
    centring_gain: float = 0.3100
    frontal_gain: float = 1.224
    frontal_threshold: float = 0.2790
    yaw_gain: float = 0.1088
    obstacle_rows: int = 2
    flight_height: float = 1.0
    height_gain: float = 2.0
    heading_gain: float = 1.0

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        histogram = np.asarray(observation["depth_histogram"], np.float64)
        batched = histogram.ndim == 4
        histogram = histogram.reshape((-1, *histogram.shape[-3:]))
        check_bins(histogram, self.bin_edges)
        nearness = sector_nearness(histogram[:, : self.obstacle_rows], np.asarray(self.bin_edges))
        actions = self.centring_actions(nearness, observation)
        return (actions if batched else actions[0]), state

    def centring_actions(self, nearness: np.ndarray, observation: dict[str, np.ndarray]) -> np.ndarray:
        """The bee's steering law on a nearness per sector (batch, obstacle rows, cols): (batch, 3) actions."""
        heights, headings, _ = heights_and_headings(observation)
        per_column = nearness.max(axis=1)  # (batch, cols): the nearest thing in each column
        left = band_mean(per_column, Fraction(0), SIDE_SHARE)
        right = band_mean(per_column, 1 - SIDE_SHARE, Fraction(1))
        centre = per_column[:, band_columns(per_column.shape[1], SIDE_SHARE, 1 - SIDE_SHARE)].max(axis=1)
        # Positive lateral action moves right: away from a nearer left side.
        side = np.where(left >= right, 1.0, -1.0)
        looming = np.maximum(centre - self.frontal_threshold, 0.0)
        lateral = self.centring_gain * (left - right) + self.frontal_gain * looming * side
        actions = np.zeros((len(heights), 3), np.float32)
        actions[:, 0] = np.clip(lateral, -1, 1)
        actions[:, 1] = np.clip(self.height_gain * (self.flight_height - heights), -1, 1)
        actions[:, 2] = np.clip(self.heading_gain * headings + self.yaw_gain * looming * side, -1, 1)
        return actions
