"""Report templates: the prose lives in a text file, every figure and every verdict comes from the data.

A writer computes a dict of named values from its measured rows and fills a template file with it. Two kinds
of tag, both in double braces:

* ``{{name}}``: replaced by ``values[name]``, which must be a ``str``. Numbers are formatted by the code that
  computes them, so a template never decides how many digits a figure gets.
* ``{{if name}} ... {{else}} ... {{end}}``: the first part when ``values[name]`` (a ``bool``) is true, else the
  part after ``{{else}}`` (optional). Sections may nest. This is how a sentence that makes a claim ("met",
  "x is faster") is chosen by the data: the template holds every wording, the code decides which one holds.

A block tag (``if``/``else``/``end``) alone on its line takes that whole line with it, newline included, so
sections do not leave blank lines behind; anywhere else a tag is replaced in place. There is no escape for a
literal ``{{``.

Filling fails loudly, with a ``ValueError`` naming the template and the field, when a field on the rendered
path has no value, when a value is given that the template never mentions, or when a value has the wrong type:
a template cannot drift from its data unnoticed. Fields inside a section that is skipped need no value (a
figure that only exists when its claim holds).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

# A block tag alone on its line (group 1) is matched first, so it takes its line along; then any tag (group 2).
_TAGS = re.compile(
    r"^[ \t]*\{\{\s*((?:if\s+\w+|else|end))\s*\}\}[ \t]*(?:\n|\Z)|\{\{(.*?)\}\}",
    re.MULTILINE,
)
_NAME = re.compile(r"\w+")


@dataclass
class _Section:
    """An ``{{if name}}`` section: the parts for a true and a false condition."""

    name: str
    line: int
    when_true: list[str | _Field | _Section] = field(default_factory=list)
    when_false: list[str | _Field | _Section] = field(default_factory=list)
    in_else: bool = False

    def parts(self) -> list[str | _Field | _Section]:
        return self.when_false if self.in_else else self.when_true


@dataclass(frozen=True)
class _Field:
    name: str
    line: int


def load_template(path: str | Path) -> str:
    """The text of a template file.

    Args:
        path: the template file (UTF-8).

    Returns:
        Its text, unchanged.

    Raises:
        FileNotFoundError: no such file.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"template file not found: {path}")
    return path.read_text(encoding="utf-8")


def render_template(path: str | Path, values: Mapping[str, str | bool], *, inline: bool = False) -> str:
    """Load a template file and fill it (see :func:`fill_template`); errors name the file.

    Args:
        path: the template file.
        values: field values (``str``) and section conditions (``bool``) by name.
        inline: drop the file's final newline, for a snippet that sits inside a line of another template.

    Returns:
        The filled text.

    Raises:
        FileNotFoundError: no such file.
        ValueError: see :func:`fill_template`.
    """
    text = load_template(path)
    if inline:
        text = text.removesuffix("\n")
    return fill_template(text, values, Path(path).name)


def fill_template(text: str, values: Mapping[str, str | bool], name: str = "template") -> str:
    """Fill a template's ``{{name}}`` fields and choose its ``{{if name}}`` sections.

    Args:
        text: the template text.
        values: field values (``str``) and section conditions (``bool``) by name.
        name: what error messages call the template (its file name).

    Returns:
        The filled text.

    Raises:
        ValueError: a malformed tag or unbalanced section; a field or condition on the rendered path without a
            value; a value the template never mentions; a field given a non-``str`` or a condition a
            non-``bool``.
    """
    parts, mentioned = _parse(text, name)
    unused = sorted(set(values) - mentioned)
    if unused:
        raise ValueError(f"template {name!r}: value {unused[0]!r} is not used by the template (drifted?)")
    out: list[str] = []
    _render(parts, values, name, out)
    return "".join(out)


def _parse(text: str, name: str) -> tuple[list[str | _Field | _Section], set[str]]:
    """The template as a tree of text, fields and sections, and every name it mentions."""
    root: list[str | _Field | _Section] = []
    open_sections: list[_Section] = []
    mentioned: set[str] = set()
    position = 0
    for match in _TAGS.finditer(text):
        current = open_sections[-1].parts() if open_sections else root
        current.append(text[position : match.start()])
        position = match.end()
        line = text.count("\n", 0, match.start()) + 1
        tag = " ".join((match.group(1) or match.group(2)).split())
        words = tag.split(" ")
        if words[0] == "if" and len(words) == 2 and _NAME.fullmatch(words[1]):
            section = _Section(words[1], line)
            current.append(section)
            open_sections.append(section)
            mentioned.add(words[1])
        elif tag in ("else", "end") and open_sections:
            if tag == "end":
                open_sections.pop()
            elif open_sections[-1].in_else:
                raise ValueError(f"template {name!r}: a second {{{{else}}}} in one section on line {line}")
            else:
                open_sections[-1].in_else = True
        elif tag in ("else", "end"):
            raise ValueError(
                f"template {name!r}: {{{{{tag}}}}} outside any {{{{if}}}} section on line {line}"
            )
        elif _NAME.fullmatch(tag) and tag != "if":
            current.append(_Field(tag, line))
            mentioned.add(tag)
        else:
            raise ValueError(
                f"template {name!r}: bad tag {{{{{tag}}}}} on line {line}; allowed: "
                "{{name}}, {{if name}}, {{else}}, {{end}}"
            )
    if open_sections:
        unclosed = open_sections[-1]
        raise ValueError(
            f"template {name!r}: {{{{if {unclosed.name}}}}} on line {unclosed.line} has no {{{{end}}}}"
        )
    root.append(text[position:])
    return root, mentioned


def _render(
    parts: list[str | _Field | _Section], values: Mapping[str, str | bool], name: str, out: list[str]
) -> None:
    for part in parts:
        if isinstance(part, str):
            out.append(part)
            continue
        if part.name not in values:
            kind = "field" if isinstance(part, _Field) else "condition"
            raise ValueError(f"template {name!r}: {kind} {part.name!r} (line {part.line}) has no value")
        value = values[part.name]
        if isinstance(part, _Field):
            if not isinstance(value, str):
                raise ValueError(
                    f"template {name!r}: field {part.name!r} must be text (format numbers in the code), "
                    f"got {type(value).__name__}"
                )
            out.append(value)
        elif not isinstance(value, bool):
            raise ValueError(
                f"template {name!r}: condition {part.name!r} must be a bool, got {type(value).__name__}"
            )
        else:
            _render(part.when_true if value else part.when_false, values, name, out)
