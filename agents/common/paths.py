"""Where the project's own folders are: the repository root and what the commands read and write there."""

from __future__ import annotations

from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[2]
CONFIGS_DIR = REPO_ROOT / "configs"
RESULTS_DIR = REPO_ROOT / "results"
POLICIES_DIR = RESULTS_DIR / "policies"
