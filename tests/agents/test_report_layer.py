"""One layer writes pages: no module under ``agents/evaluation/`` writes Markdown. Evaluation scores and returns
typed values; :mod:`agents.pages` (the templates, the wording and the pages over evaluation's values) and
:mod:`agents.reports` (the registry, and the pages over the studies' values) turn them into pages.

The scan reads each module's syntax tree: it flags an import of a template engine or of the Markdown helpers,
and a ``.md`` file name that a module writes to or joins onto a folder. Naming a page in prose (a docstring
that says ``suite.md`` words a value) is not writing it.
"""

from __future__ import annotations

import ast
from pathlib import Path

from agents.common.locations import REPO_ROOT

EVALUATION = REPO_ROOT / "agents" / "evaluation"
# What renders or words a page: the template engine, the renderer over it, the layers that write pages, and the
# Markdown table helpers.
PAGE_MODULES = ("jinja2", "agents.common.jinja_reports", "agents.pages", "agents.reports")
MARKDOWN_HELPERS = {"markdown_table", "markdown_cell"}
# Calls that write a file named by one of their arguments, or open one to write.
WRITE_CALLS = {"write_text", "write_text_atomically", "open", "Path", "copyfile"}


def _is_page_module(name: str) -> bool:
    return any(name == module or name.startswith(f"{module}.") for module in PAGE_MODULES)


def _markdown_name(node: ast.AST) -> bool:
    """Whether ``node`` is a string constant (or f-string) naming a ``.md`` file."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return node.value.endswith((".md", ".md.j2"))
    if isinstance(node, ast.JoinedStr) and node.values:
        return _markdown_name(node.values[-1])
    return False


def _call_name(node: ast.Call) -> str:
    return node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", "")


def _import_findings(node: ast.AST) -> list[str]:
    if isinstance(node, ast.Import):
        return [f"imports {alias.name}" for alias in node.names if _is_page_module(alias.name)]
    if isinstance(node, ast.ImportFrom) and node.module:
        if _is_page_module(node.module):
            return [f"imports {node.module}"]
        helpers = sorted(alias.name for alias in node.names if alias.name in MARKDOWN_HELPERS)
        return [f"imports {node.module}.{name}" for name in helpers]
    return []


def _write_findings(node: ast.AST) -> list[str]:
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Div) and _markdown_name(node.right):
        return ["joins a .md file name onto a folder"]
    if isinstance(node, ast.Call) and _call_name(node) in WRITE_CALLS:
        if any(_markdown_name(argument) for argument in node.args):
            return [f"passes a .md file name to {_call_name(node)}()"]
    return []


def markdown_writes(source: str) -> list[str]:
    """What in the module ``source`` writes Markdown, a line each (``line 3: imports jinja2``); empty if nothing."""
    found = [
        (getattr(node, "lineno", 0), finding)
        for node in ast.walk(ast.parse(source))
        for finding in (*_import_findings(node), *_write_findings(node))
    ]
    return [f"line {line}: {finding}" for line, finding in sorted(found)]


def test_no_module_under_evaluation_writes_markdown() -> None:
    modules = sorted(EVALUATION.rglob("*.py"))
    assert len(modules) > 20  # the scan reads the real package, not an empty folder
    found = {
        path.relative_to(REPO_ROOT).as_posix(): markdown_writes(path.read_text())
        for path in modules
        if markdown_writes(path.read_text())
    }
    assert found == {}, "evaluation returns values; its pages belong in agents/pages"


def test_evaluation_keeps_no_templates() -> None:
    assert not (EVALUATION / "templates").exists()
    assert not list(EVALUATION.rglob("*.j2"))
    assert list((REPO_ROOT / "agents" / "pages" / "templates").glob("suite*.md.j2"))  # they moved there


def test_the_scan_catches_a_module_that_writes_a_page(tmp_path: Path) -> None:
    offending = tmp_path / "offending.py"
    offending.write_text(
        '"""Writes suite.md."""\n'
        "from pathlib import Path\n"
        "from agents.common.jinja_reports import render\n"
        "from agents.common.tables import markdown_table, today\n"
        "import jinja2\n"
        "\n"
        "def write(out: Path, name: str) -> None:\n"
        '    (out / "suite.md").write_text(render("agents.pages", "suite.md.j2", {}))\n'
        '    Path(f"{name}.md").write_text("# page")\n'
        '    with open("notes.md", "w") as handle:\n'
        '        handle.write(markdown_table(["a"], [[1]]))\n'
    )
    assert markdown_writes(offending.read_text()) == [
        "line 3: imports agents.common.jinja_reports",
        "line 4: imports agents.common.tables.markdown_table",
        "line 5: imports jinja2",
        "line 8: joins a .md file name onto a folder",
        "line 9: passes a .md file name to Path()",
        "line 10: passes a .md file name to open()",
    ]


def test_the_scan_leaves_prose_and_data_alone() -> None:
    clean = (
        '"""The ranking ``suite.md`` words; its page is agents.pages.suite_page\'s."""\n'
        "from pathlib import Path\n"
        "from agents.common.tables import today, write_csv\n"
        "\n"
        "PAGE_LINK = 'suite_v2_calibration/calibration.md'  # a link another page shows, not a file written here\n"
        "\n"
        "def write(out: Path) -> None:\n"
        '    write_csv(out / "suite.csv", [])\n'
    )
    assert markdown_writes(clean) == []
