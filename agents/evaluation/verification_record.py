"""What ``flownav verify`` leaves beside a ``score.csv`` it verified (``verification.json``), and what
``flownav leaderboard --include`` reads from it: rows are verified only while the file and its episodes are
byte for byte the ones verified; any other row is self-reported."""

from __future__ import annotations

import json
from pathlib import Path

from agents.common.folders import write_text_atomically
from agents.common.manifest import file_sha256
from agents.common.tables import today

VERIFICATION_JSON = "verification.json"
# The episodes file flownav score writes beside score.csv (agents.evaluation.suite.EPISODES_CSV).
EPISODES_BESIDE = "suite_episodes.csv"


def write_verification(score_csv: Path, checked: int, episodes_csv: str | Path | None = None) -> Path:
    """Record beside ``score_csv`` that ``checked`` of its episodes were flown again and matched, with the
    hashes of the two files; returns where."""
    episodes = Path(episodes_csv) if episodes_csv else score_csv.parent / EPISODES_BESIDE
    record = {
        "score_sha256": file_sha256(score_csv),
        "episodes_sha256": file_sha256(episodes),
        "episodes_reflown": checked,
        "verified": today(),
    }
    path = score_csv.parent / VERIFICATION_JSON
    write_text_atomically(path, json.dumps(record, indent=2) + "\n")
    return path


def verification_mark(score_csv: Path) -> str:
    """How ``flownav leaderboard --include`` marks the rows of ``score_csv``: ``verified (k episodes re-flown)``
    where ``verification.json`` beside it vouches for this very file and its episodes, else ``self-reported``."""
    path = score_csv.parent / VERIFICATION_JSON
    episodes = score_csv.parent / EPISODES_BESIDE
    try:
        record = json.loads(path.read_text())
        checked = record["episodes_reflown"]
        matches = (
            record["score_sha256"] == file_sha256(score_csv)
            and episodes.is_file()
            and record["episodes_sha256"] == file_sha256(episodes)
        )
    except (OSError, ValueError, KeyError, TypeError):
        return "self-reported"
    if not matches or type(checked) is not int or checked < 1:
        return "self-reported"
    return f"verified ({checked} episodes re-flown)"
