"""What ``flownav verify`` leaves beside a ``score.csv`` it verified (``verification.json``), and what
``flownav leaderboard --include`` reads from it.

Rows are verified only while three things hold: the record is signed with this user's key
(:mod:`agents.common.signing`, which no outside agent's sandbox shows and no one else can read), and the score
file and its episodes are byte for byte the ones verified. A record written by hand, by another user, or for
other files marks the rows self-reported.
"""

from __future__ import annotations

import json
from pathlib import Path

from agents.common.folders import write_text_atomically
from agents.common.manifest import file_sha256
from agents.common.signing import sign, signed_by_this_user
from agents.common.tables import today

VERIFICATION_JSON = "verification.json"
# The episodes file flownav score writes beside score.csv (agents.evaluation.suite.EPISODES_CSV).
EPISODES_BESIDE = "suite_episodes.csv"
SELF_REPORTED = "self-reported"


def write_verification(
    score_csv: Path,
    checked: int,
    episodes_csv: str | Path | None = None,
    *,
    statistically: int = 0,
    cpu: str = "",
) -> Path:
    """Record beside ``score_csv``, signed with this user's key, that ``checked`` of its episodes were flown again
    and matched (``statistically`` of them flown on another CPU than the file's, ``cpu`` this one), with the hashes
    of the two files; returns where."""
    episodes = Path(episodes_csv) if episodes_csv else score_csv.parent / EPISODES_BESIDE
    record: dict[str, object] = {
        "score_sha256": file_sha256(score_csv),
        "episodes_sha256": file_sha256(episodes),
        "episodes_reflown": checked,
        "compared_statistically": statistically,
        "cpu": cpu,
        "verified": today(),
    }
    record["signature"] = sign(record)
    path = score_csv.parent / VERIFICATION_JSON
    write_text_atomically(path, json.dumps(record, indent=2) + "\n")
    return path


def verification_mark(score_csv: Path) -> str:
    """How ``flownav leaderboard --include`` marks the rows of ``score_csv``: ``verified (k episodes re-flown)``
    where a ``verification.json`` beside it, signed with this user's key, vouches for this very file and its
    episodes, else ``self-reported``."""
    path = score_csv.parent / VERIFICATION_JSON
    episodes = score_csv.parent / EPISODES_BESIDE
    try:
        record = json.loads(path.read_text())
        signature = record.pop("signature", None)
        checked = record["episodes_reflown"]
        matches = (
            signed_by_this_user(record, signature)
            and record["score_sha256"] == file_sha256(score_csv)
            and episodes.is_file()
            and record["episodes_sha256"] == file_sha256(episodes)
        )
        statistically = record.get("compared_statistically", 0)
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return SELF_REPORTED
    if not matches or type(checked) is not int or checked < 1 or type(statistically) is not int:
        return SELF_REPORTED
    how = f", {statistically} of them on another CPU, compared statistically" if statistically else ""
    return f"verified ({checked} episodes re-flown{how})"
