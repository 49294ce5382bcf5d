"""The Jinja2 reports (agents.common.jinja_reports): block tags take their line, a missing value fails, and a
writer can insist that every value it gives is named."""

from __future__ import annotations

import dataclasses

import jinja2
import pytest

from agents.common.jinja_reports import environment, names_in, render, template_source, unused_values
from agents.studies.perf.estimator_speed_report import VerdictValues


def _render(text: str, **values: object) -> str:
    # The studies' environment, on a template given as text: the same whitespace rules and filters.
    return environment("agents.pages").from_string(text).render(**values)


def test_a_block_tag_alone_on_its_line_takes_the_line() -> None:
    text = "head\n  {% if extra %}\n## Extra\n{% endif %}\nend\n"
    assert _render(text, extra=True) == "head\n## Extra\nend\n"
    assert _render(text, extra=False) == "head\nend\n"


def test_an_inline_block_tag_before_a_newline_keeps_it_when_asked() -> None:
    assert _render("a {% if x %}b{% endif %}\nc", x=True) == "a bc"
    assert _render("a {% if x %}b{% endif +%}\nc", x=True) == "a b\nc"


def test_a_missing_value_fails_and_filters_format_numbers() -> None:
    with pytest.raises(jinja2.UndefinedError):
        _render("{{ speed }} m/s")
    assert _render("{{ x | rate }} {{ d | signed }} {{ p | p_value }}", x=0.25, d=0.0214, p=0.0004) == (
        "0.25 +0.021 < 0.001"
    )


def test_names_and_unused_values() -> None:
    text = "{% if met %}{{ value }}{% else %}{{ low | interval(high) }}{% endif %}"
    assert names_in(text) == {"met", "value", "low", "high"}
    assert unused_values(text, {"met": True, "value": "1", "stale": "2"}) == ["stale"]
    assert "board" in names_in(template_source("agents.pages", "benchmark.md.j2"))


@dataclasses.dataclass(frozen=True)
class _StaleVerdict(VerdictValues):
    """A verdict's values with one its template does not name."""

    stale: str


def test_every_value_used_names_the_template_and_the_value() -> None:
    names = names_in(template_source("agents.studies.perf", "target_verdict.md.j2"))
    fields = {name: "1" for name in names} | {"swept": True, "met": True}
    with pytest.raises(ValueError, match=r"template 'target_verdict\.md\.j2': value 'stale' is not used"):
        render(
            "agents.studies.perf",
            "target_verdict.md.j2",
            _StaleVerdict(**fields, stale="x"),
            every_value_used=True,
        )
    assert render(
        "agents.studies.perf", "target_verdict.md.j2", VerdictValues(**fields), every_value_used=True
    ).startswith("1× → **met**")


def test_a_mapping_of_values_is_refused_naming_the_template() -> None:
    # Each template gets a frozen dataclass of its values, which mypy checks; a dictionary's keys it cannot.
    with pytest.raises(
        TypeError, match=r"^template 'suite\.md\.j2': values must be a dataclass instance"
    ) as raised:
        render("agents.pages", "suite.md.j2", {"tiers": []})  # type: ignore[arg-type]
    assert "\n" not in str(raised.value) and str(raised.value).endswith("got dict")
    with pytest.raises(TypeError, match="got type"):
        render("agents.studies.perf", "target_verdict.md.j2", VerdictValues)  # type: ignore[arg-type]
