"""Reports as Jinja2 templates over values: one function computes a frozen dataclass of numbers and tables from
the committed data (its fields typed, so mypy checks what a template is given), one template
(``<package>/templates/*.md.j2``) words it, and the small filters here turn a number into text. Markdown needs no
escaping, and an undefined value is an error rather than an empty string.

Block tags alone on their line take the line with them (``trim_blocks``, ``lstrip_blocks``), so sections leave no
blank lines behind; a block tag inside a line that ends it is written ``{% endif +%}`` to keep the newline.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

import jinja2
import jinja2.meta
import jinja2.nodes

if (
    TYPE_CHECKING
):  # typeshed's protocol of a dataclass instance: for annotations only, not importable at run time
    from _typeshed import DataclassInstance


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


def render(
    package: str,
    template: str,
    values: DataclassInstance,
    *,
    every_value_used: bool = False,
    filters: Mapping[str, Callable[..., object]] | None = None,
) -> str:
    """``package``'s ``templates/<template>`` rendered with ``values``.

    Args:
        package: the package whose ``templates/`` folder holds the template.
        template: its file name.
        values: what it names: a frozen dataclass's fields (each as it is: a nested dataclass stays one, and
            Jinja reads its attributes as it reads a mapping's keys).
        every_value_used: also fail on a value the template never names: for a writer that computes its
            values for this one template, a value left unused means the template drifted from its data.
        filters: the package's own filters beside :data:`FILTERS` (added to its environment once given).

    Raises:
        TypeError: ``values`` is not a dataclass instance (a mapping's keys are not checked by mypy).
        jinja2.TemplateNotFound: no such template.
        jinja2.UndefinedError: the template names a value ``values`` lacks (on the path it renders).
        ValueError: ``every_value_used`` and a value the template never names.
    """
    if not dataclasses.is_dataclass(values) or isinstance(values, type):
        raise TypeError(
            f"template {template!r}: values must be a dataclass instance (each template gets a frozen dataclass "
            f"of its values), got {type(values).__name__}"
        )
    named = template_fields(values)
    if every_value_used:
        unused = unused_values(template_source(package, template), named)
        if unused:
            raise ValueError(
                f"template {template!r}: value {unused[0]!r} is not used by the template (drifted?)"
            )
    made = environment(package)
    made.filters.update(filters or {})
    return made.get_template(template).render(**named)


def template_fields(values: DataclassInstance) -> dict[str, object]:
    """The names a template is given from ``values``: a dataclass's fields, shallowly (``dataclasses.asdict``
    would copy every nested value and turn a nested dataclass into a dictionary)."""
    return {field.name: getattr(values, field.name) for field in dataclasses.fields(values)}


def names_in(source: str) -> frozenset[str]:
    """Every value a template's text names (in a field, a condition or a filter's argument), whichever filters
    it applies: a package's own (:data:`FILTERS`, or those its renderer adds) need not be known here."""
    scratch = jinja2.Environment()
    tree = scratch.parse(source)
    # Finding the names walks the template as compiling it does, and that fails on a filter the environment
    # lacks; what a filter does cannot change which names the text uses, so each unknown one stands in as a no-op.
    for node in tree.find_all(jinja2.nodes.Filter):
        scratch.filters.setdefault(node.name, _stand_in)
    return frozenset(jinja2.meta.find_undeclared_variables(tree))


def _stand_in(value: object, *args: object, **kwargs: object) -> object:
    """A filter that is never called: it lets :func:`names_in` walk a template that applies an unknown one."""
    return value


def template_source(package: str, template: str) -> str:
    """The text of ``package``'s ``templates/<template>``."""
    made = environment(package)
    assert made.loader is not None  # environment() always gives one
    source, _, _ = made.loader.get_source(made, template)
    return source


def unused_values(source: str, values: Mapping[str, object]) -> list[str]:
    """The names in ``values`` that the template text ``source`` never names, sorted."""
    return sorted(set(values) - names_in(source))
