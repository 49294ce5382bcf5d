"""Resolutions of the depth histogram an agent may ask any tier for: ``histogram_sectors`` and
``depth_bin_edges`` are observation settings (``flownav_env.tiers.AGENT_OBSERVATION_SETTINGS``), the same
estimated depths binned finer or coarser, never another task. A rule asks for one with the env settings and
flies it with matching ``bin_edges``: :class:`HistogramResolution` gives both."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from flownav_env.settings import EnvSettings
from flownav_env.settings_check import check_env_kwargs

# The camera-limited planner's flow student's bins (configs/experiments/ppo_flow_camera_student_fine_rounds6.yaml):
# half a metre wide up to 3 m, where a capsule must be avoided, then the default's.
FINE_BIN_EDGES: tuple[float, ...] = (0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 5.0, 8.0, 13.0)


@dataclass(frozen=True)
class HistogramResolution:
    """A depth histogram's resolution: sector rows and columns of the image, and the depth bin edges (m).

    Raises:
        ValueError: sectors or bin edges the env would refuse (one line naming the value and its range).
    """

    sectors: tuple[int, int] = EnvSettings().histogram_sectors
    bin_edges: tuple[float, ...] = EnvSettings().depth_bin_edges

    def __post_init__(self) -> None:
        check_env_kwargs(
            {"histogram_sectors": self.sectors, "depth_bin_edges": self.bin_edges},
            "histogram resolution",
            key="resolution",
        )

    @property
    def name(self) -> str:
        """``3x15``, with the bin count where the bins are not the env's default (``3x15-9bins``)."""
        rows, cols = self.sectors
        default_bins = self.bin_edges == EnvSettings().depth_bin_edges
        return f"{rows}x{cols}" + ("" if default_bins else f"-{len(self.bin_edges) - 1}bins")

    def env_kwargs(self) -> dict[str, object]:
        """The env settings that ask for this resolution: those that differ from the env's defaults."""
        wanted = {"histogram_sectors": self.sectors, "depth_bin_edges": self.bin_edges}
        defaults = EnvSettings()
        return {key: value for key, value in wanted.items() if getattr(defaults, key) != value}

    def rule_parameters(self) -> dict[str, Any]:
        """A rule's parameters that read this resolution: its ``bin_edges`` where they are not the default."""
        return {} if self.bin_edges == EnvSettings().depth_bin_edges else {"bin_edges": self.bin_edges}
