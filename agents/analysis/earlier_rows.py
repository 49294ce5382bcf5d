"""Episodes CSVs written by earlier code, read as today's rows.

The record (:class:`~agents.analysis.episode_record.EpisodeRecord`) says what an episode is now. Files written
before some of its columns existed are still read, and still appended to in their own columns, so that
resuming into a committed CSV never flies its episodes again. What that takes lives here, on the reading side:

- the headers of earlier files (:func:`earlier_headers`): today's columns without those added since;
- :func:`upgrade_row`: an earlier row given today's columns, None (unknown) for each one its file predates;
- :func:`exclusive_outcome`: the one outcome of an episode recorded before the env made its end flags
  exclusive.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from agents.analysis.episode_record import EpisodeRow, episode_outcome

ADDED_FIELDS = ("mean_depth_outlier_share", "suite_version", "max_abs_lateral_m", "isolation", "cpu")
"""Columns added since episodes carried their identities, oldest first; each sits after the earlier ones at the
end of the record, so an earlier file's header is today's with the later additions left out."""


def earlier_headers(current: Sequence[str]) -> list[list[str]]:
    """The headers of files written before each of :data:`ADDED_FIELDS`: entry ``k`` is ``current`` (today's
    CSV columns) without ``ADDED_FIELDS[k:]``, so entry 0 is the oldest."""
    return [
        [name for name in current if name not in ADDED_FIELDS[since:]] for since in range(len(ADDED_FIELDS))
    ]


def upgrade_row(raw: Mapping[str, str], columns: Sequence[str]) -> dict[str, str | None]:
    """``raw`` (one line's text values, keyed by its file's header) with exactly ``columns`` (today's record
    fields): a column the file's format predates is None, unknown rather than guessed."""
    return {name: raw.get(name) for name in columns}


def exclusive_outcome(row: EpisodeRow) -> EpisodeRow:
    """``row`` with its ``collision``, ``out_of_bounds`` and ``success`` made exclusive by the env's rule
    (:func:`~agents.analysis.episode_record.episode_outcome`): episodes recorded before the rule, whose last
    step could hold a goal reached out of bounds or a collision out of bounds, count once, as the env now ends
    them. Their flights are unchanged: the flags are those of the same last step."""
    ended = episode_outcome(bool(row["collision"]), bool(row["out_of_bounds"]), bool(row["success"]))
    row["collision"], row["out_of_bounds"] = ended == "collision", ended == "out_of_bounds"
    row["success"] = ended == "success"
    return row
