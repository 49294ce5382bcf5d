"""Reports as Jinja2 templates over values: one function computes a dictionary of numbers and tables from the
committed data, one template (``<package>/templates/*.md.j2``) words it, and the small filters here turn a
number into text. Markdown needs no escaping, and an undefined value is an error rather than an empty string.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from typing import Any

import jinja2


def rate(value: float) -> str:
    """A rate to two decimals: ``0.25``."""
    return f"{value:.2f}"


def signed(value: float, digits: int = 3) -> str:
    """A difference with its sign: ``+0.021``."""
    return f"{value:+.{digits}f}"


def p_value(value: float) -> str:
    """A p-value to three decimals, or a bound below that: ``< 0.001``."""
    return "< 0.001" if value < 0.001 else f"{value:.3f}"


def interval(low: float, high: float, digits: int = 2) -> str:
    """``[low, high]`` to ``digits`` decimals; ``[n/a]`` for a missing bound."""
    if any(math.isnan(bound) for bound in (low, high)):
        return "[n/a]"
    return f"[{low:.{digits}f}, {high:.{digits}f}]"


FILTERS = {"rate": rate, "signed": signed, "p_value": p_value, "interval": interval}


@functools.cache
def environment(package: str) -> jinja2.Environment:
    """The Jinja2 environment of ``package``'s ``templates/`` folder, with :data:`FILTERS`."""
    made = jinja2.Environment(
        loader=jinja2.PackageLoader(package, "templates"),
        autoescape=False,
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
        trim_blocks=True,
        lstrip_blocks=True,
    )
    made.filters.update(FILTERS)
    return made


def render(package: str, template: str, values: Mapping[str, Any]) -> str:
    """``package``'s ``templates/<template>`` rendered with ``values``.

    Raises:
        jinja2.TemplateNotFound: no such template.
        jinja2.UndefinedError: the template names a value ``values`` lacks.
    """
    return environment(package).get_template(template).render(**values)
