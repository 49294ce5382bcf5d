"""The suite's rows as a Markdown table per tier, best agent first, an included row marked: what
``flownav score`` prints of the rows it wrote."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from agents.common.tables import markdown_cell, markdown_table
from agents.evaluation.suite_report import OUTCOMES, SuiteRow, outcome_interval
from flownav_env.tiers import SUITE_VERSION, TIER_NAMES, tier


def _interval(row: SuiteRow, outcome: str) -> str:
    rate, low, high = outcome_interval(row, outcome)
    return f"{rate:.2f} [{low:.2f}, {high:.2f}]"


def tier_tables(rows: Sequence[SuiteRow]) -> list[str]:
    """A markdown table per tier, best agent first; an included row is marked."""
    lines: list[str] = []
    for name in TIER_NAMES:
        mine = sorted((r for r in rows if r["tier"] == name), key=lambda r: (r["failure_rate"], r["agent"]))
        if not mine:
            continue
        spec = tier(name, str(mine[0].get("suite_version") or SUITE_VERSION))
        lines += [f"### `{name}` (`{spec.env_id}`)", "", spec.why + ".", ""]
        table_rows = [
            [
                f"`{markdown_cell(r['agent'])}`" + _included_mark(r),
                r["runs"],
                r["layouts"],
                *(_interval(r, outcome) for outcome in OUTCOMES),
            ]
            for r in mine
        ]
        header = ["agent", "runs", "layouts", *(f"{o.replace('_', ' ')} [95 % CI]" for o in OUTCOMES)]
        lines += [markdown_table(header, table_rows), ""]
    return lines


def _included_mark(row: Mapping[str, object]) -> str:
    """`` (included, verified ...)`` or `` (included, self-reported)`` for an included row (its ``included``
    says which, :func:`agents.evaluation.verification_record.verification_mark`); "" for a published one."""
    mark = row.get("included")
    if not mark:
        return ""
    return f" (included, {mark})" if isinstance(mark, str) else " (included)"
