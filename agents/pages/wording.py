"""How the studies' reports are rendered: their Jinja2 templates in ``templates/`` (the shared phrases in
``wording.j2``) with the filters that turn a value into words, beside :mod:`agents.common.jinja_reports`'s."""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import TYPE_CHECKING

from agents.analysis.dose_response import format_p
from agents.analysis.paired import provisional_note
from agents.common.jinja_reports import environment, render
from agents.common.study_choices import choices
from agents.policies.base import base_agent_name

if TYPE_CHECKING:
    from _typeshed import DataclassInstance

PACKAGE = "agents.pages"


def display_name(agent: str) -> str:
    """How the reports name an agent: its base name in backticks, the lever search's winner "the winner"."""
    base = base_agent_name(agent)
    return "the winner" if base == choices().winner else f"`{base}`"


def join_words(words: Iterable[str], last: str = "and") -> str:
    """``a``; ``a and b``; ``a, b and c`` (``last`` may be "or")."""
    words = list(words)
    return f"{', '.join(words[:-1])} {last} {words[-1]}" if len(words) > 1 else "".join(words)


def span(values: Iterable[float], digits: int = 0) -> str:
    """``36–59``: the smallest and largest value, or one where they print alike."""
    values = list(values)
    low, high = f"{min(values):,.{digits}f}", f"{max(values):,.{digits}f}"
    return low if low == high else f"{low}–{high}"


def level_text(level: float | None, unit: str = "") -> str:
    """A factor level with its unit (``0.5°``, ``1.5 m/s``), or "no level flown" for None."""
    if level is None:
        return "no level flown"
    return f"{level:g}{unit}" if unit.startswith("°") or not unit else f"{level:g} {unit}"


def num(value: float | None, digits: int = 1) -> str:
    """``value`` to ``digits`` decimals; a dash where it is missing."""
    return "–" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.{digits}f}"


def pct(value: float | None) -> str:
    """A fraction as a percentage to one decimal; a dash where it is missing."""
    return (
        "–" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{100 * value:.1f} %"
    )


FILTERS = {
    "display": display_name,
    "names": join_words,
    "span": span,
    "level": level_text,
    "count": lambda value: f"{value:,.0f}",
    "p": format_p,
    "num": num,
    "pct": pct,
    # A comparison's note on the learned agents in it that pooled too few training seeds to rank (or "").
    "provisional": lambda comparison: (
        provisional_note(comparison) if hasattr(comparison, "agent_runs") else ""
    ),
}


# The package's one environment (agents.common.jinja_reports keeps one per package) gets these filters here,
# once, as this module is imported: every render of the package's templates through it words values alike.
environment(PACKAGE).filters.update(FILTERS)


def render_report(template: str, values: DataclassInstance) -> str:
    """This package's ``template`` rendered with ``values``, its filters those of :data:`FILTERS` and
    :mod:`agents.common.jinja_reports`'s."""
    return render(PACKAGE, template, values)
