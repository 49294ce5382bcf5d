"""Where the project's own folders are: the repository root and what the commands read and write there."""

from __future__ import annotations

from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[2]
CONFIGS_DIR = REPO_ROOT / "configs"
RESULTS_DIR = REPO_ROOT / "results"
POLICIES_DIR = RESULTS_DIR / "policies"
# What a command writes by default goes to scratch under the current folder, never over a committed report:
# results/ is written only when --out names it.
SCRATCH_DIR = Path("runs")
