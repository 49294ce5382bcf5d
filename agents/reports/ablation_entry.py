"""A committed ``ablation.md`` as the registry (:mod:`agents.reports.report_registry`) rebuilds it: the options of
``flownav ablation`` it was written with, as named fields, from which both the command the report names and the
in-process writer call are derived, so the two cannot disagree."""

from __future__ import annotations

import shlex
import tempfile
from dataclasses import dataclass
from pathlib import Path

from agents.common.locations import REPO_ROOT
from agents.reports.report_entry import Report
from agents.studies.ablation import compare_configs
from flownav_env.tiers import SUITE_VERSION


@dataclass(frozen=True)
class AblationSpec:
    """The options of ``flownav ablation --report-only`` behind one committed ``ablation.md``.

    Attributes:
        folder: where the report lives, relative to ``results/`` (``--out results/<folder>``).
        configs: the training configs compared, relative to the repository root (``--configs``).
        layouts: validation layouts per run (``--layouts``).
        env: the FlowNavEnv settings every run flies with, in the order given (``--env key=value`` each).
        seeds: the training seeds of each config (``--seeds``).
        reference: the reactive agents flown beside them (``--reference``).
        tier: a suite tier whose course, sensor and validation layouts are flown instead (``--tiers``).
        suite_version: the tier's suite version (``--suite-version``, the current one by default as there;
            written only with a tier, the only one it matters for).
        confirm: fly the tier's confirmation layouts instead of its recipe layouts (``--confirm``).
    """

    folder: str
    configs: tuple[str, ...]
    layouts: int
    env: tuple[tuple[str, object], ...] = ()
    seeds: tuple[int, ...] = (0, 1, 2, 3, 4)
    reference: tuple[str, ...] = ("bee_robust", "bee_ttc")
    tier: str | None = None
    suite_version: str = SUITE_VERSION
    confirm: bool = False

    @property
    def name(self) -> str:
        """What ``flownav reports --only`` calls the report: its folder with dashes (``ablation-speed-1.5``)."""
        return self.folder.replace("/", "-").replace("_", "-")

    @property
    def command(self) -> str:
        """The ``flownav ablation`` call that rebuilds the report from the committed data."""
        words = ["flownav", "ablation", "--configs", *self.configs]
        words += ["--seeds", ",".join(map(str, self.seeds)), "--reference", ",".join(self.reference)]
        words += ["--layouts", str(self.layouts)]
        for key, value in self.env:
            words += ["--env", f"{key}={value}"]
        if self.tier:
            words += ["--tiers", self.tier, "--suite-version", self.suite_version]
        if self.confirm:
            words.append("--confirm")
        return shlex.join([*words, "--out", f"results/{self.folder}", "--report-only"])

    def write(self, report: Report, folder: Path) -> None:
        """Rebuild the report into ``folder`` from the episodes there, as ``flownav ablation`` would with these
        options."""
        # Run folders (runs/) are not committed: an empty one makes every seed its shipped policy, as on a fresh
        # checkout, so the report does not depend on what this machine trained.
        with tempfile.TemporaryDirectory(prefix="flownav-no-runs-") as no_runs:
            compare_configs(
                [REPO_ROOT / config for config in self.configs],
                list(self.seeds),
                folder,
                runs_dir=Path(no_runs),
                episodes=self.layouts,
                report_only=True,
                command=report.command,
                reference_agents=list(self.reference),
                env=dict(self.env),
                tier=self.tier,
                suite_version=self.suite_version,
                confirm=self.confirm,
            )

    def report(self) -> Report:
        """The registry's entry: the report, its command, its committed inputs and its writer."""
        return Report(
            f"{self.folder}/ablation.md",
            name=self.name,
            command=self.command,
            inputs=(f"{self.folder}/*/seed_*.csv", f"{self.folder}/reference/*.csv"),
            write=self.write,
        )
