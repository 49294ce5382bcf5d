"""The report templates (agents.common.templates): fields, sections, and loud failures on drift."""

from __future__ import annotations

from pathlib import Path

import pytest

from agents.common.templates import fill_template, load_template, render_template


def test_fields_are_filled_in_place() -> None:
    assert fill_template("a {{x}} b {{ y }}{{x}}", {"x": "1", "y": "2"}) == "a 1 b 21"


def test_sections_choose_the_wording_and_may_nest() -> None:
    text = "{{if swept}}{{value}} → **{{if met}}met{{else}}missed{{end}}**{{else}}not swept{{end}}."
    assert fill_template(text, {"swept": True, "value": "1.27", "met": True}) == "1.27 → **met**."
    assert fill_template(text, {"swept": True, "value": "1.89", "met": False}) == "1.89 → **missed**."
    # A skipped section's fields and conditions need no value: the figure exists only where the claim holds.
    assert fill_template(text, {"swept": False}) == "not swept."
    assert fill_template("a{{if x}}b{{end}}c", {"x": False}) == "ac"


def test_a_block_tag_alone_on_its_line_takes_the_line_with_it() -> None:
    text = "head\n{{if extra}}\n\n## Extra\n{{end}}\n  {{if tail}}  \nend\n{{end}}"
    assert fill_template(text, {"extra": True, "tail": True}) == "head\n\n## Extra\nend\n"
    assert fill_template(text, {"extra": False, "tail": False}) == "head\n"


def test_a_missing_field_names_the_template_and_the_field() -> None:
    with pytest.raises(ValueError, match=r"template 'report\.md': field 'speed' \(line 2\) has no value"):
        fill_template("title\n{{speed}} m/s", {}, "report.md")
    with pytest.raises(ValueError, match=r"template 'report\.md': condition 'met' \(line 1\) has no value"):
        fill_template("{{if met}}yes{{end}}", {}, "report.md")


def test_an_unused_value_fails_so_the_template_cannot_drift_from_its_data() -> None:
    with pytest.raises(ValueError, match=r"template 'report\.md': value 'stale' is not used by the template"):
        fill_template("{{speed}}", {"speed": "1", "stale": "2"}, "report.md")


def test_values_of_the_wrong_type_fail() -> None:
    with pytest.raises(ValueError, match=r"field 'speed' must be text \(format numbers in the code\), got float"):
        fill_template("{{speed}}", {"speed": 1.5}, "report.md")  # type: ignore[dict-item]
    with pytest.raises(ValueError, match="condition 'met' must be a bool, got str"):
        fill_template("{{if met}}yes{{end}}", {"met": "yes"}, "report.md")


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("{{if a}}x", r"\{\{if a\}\} on line 1 has no \{\{end\}\}"),
        ("x{{end}}", r"\{\{end\}\} outside any \{\{if\}\} section on line 1"),
        ("\n{{else}}", r"\{\{else\}\} outside any \{\{if\}\} section on line 2"),
        ("{{if a}}x{{else}}y{{else}}z{{end}}", r"a second \{\{else\}\} in one section on line 1"),
        ("{{speed:.2f}}", r"bad tag \{\{speed:\.2f\}\} on line 1; allowed: \{\{name\}\}, \{\{if name\}\}"),
        ("{{if}}x{{end}}", r"bad tag \{\{if\}\} on line 1"),
    ],
)
def test_malformed_templates_fail_with_the_line(text: str, message: str) -> None:
    with pytest.raises(ValueError, match=rf"template 'report\.md': {message}"):
        fill_template(text, {"a": True}, "report.md")


def test_files_load_render_and_inline(tmp_path: Path) -> None:
    path = tmp_path / "verdict.md"
    path.write_text("{{value}}× → **{{if met}}met{{else}}missed{{end}}**\n", encoding="utf-8")
    assert load_template(path) == "{{value}}× → **{{if met}}met{{else}}missed{{end}}**\n"
    assert render_template(path, {"value": "1.2", "met": True}) == "1.2× → **met**\n"
    assert render_template(path, {"value": "1.2", "met": True}, inline=True) == "1.2× → **met**"
    with pytest.raises(ValueError, match=r"template 'verdict\.md': value 'x' is not used"):
        render_template(path, {"value": "1.2", "met": True, "x": "y"})
    with pytest.raises(FileNotFoundError, match=r"template file not found: .*missing\.md"):
        render_template(tmp_path / "missing.md", {})
