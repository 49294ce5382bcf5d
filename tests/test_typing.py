"""The three packages stay typed: ``Any`` only where no better type exists. mypy itself runs in CI
(``.ci/run``: ``mypy``, configured in pyproject's ``[tool.mypy]``); this counts what mypy cannot refuse, the
parameters annotated plainly ``Any``, which switch its checking off at that boundary."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("estimator", "flownav_env", "agents")
# The opaque recurrent ``state`` of the agent protocol and its implementations, and keyword arguments passed
# straight on to a callee that validates them: today 17.
MAX_ANY_PARAMETERS = 60


def _any_parameters(path: Path, root: Path = ROOT) -> list[str]:
    """``path:function(parameter)`` for each parameter annotated exactly ``Any`` in the module at ``path``."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        arguments = node.args
        every = [*arguments.posonlyargs, *arguments.args, *arguments.kwonlyargs]
        every += [extra for extra in (arguments.vararg, arguments.kwarg) if extra is not None]
        for argument in every:
            if argument.annotation is not None and ast.unparse(argument.annotation) in ("Any", "typing.Any"):
                found.append(f"{path.relative_to(root)}:{node.name}({argument.arg})")
    return found


def test_few_parameters_are_typed_any():
    paths = [path for package in PACKAGES for path in sorted((ROOT / package).rglob("*.py"))]
    found = [item for path in paths for item in _any_parameters(path)]
    assert len(found) <= MAX_ANY_PARAMETERS, "\n".join(found)


def test_the_count_sees_an_any_parameter(tmp_path: Path):
    module = tmp_path / "module.py"
    module.write_text("from typing import Any\n\ndef f(a: Any, *rest: Any, b: int = 0, **extra: Any) -> None: ...\n")
    assert _any_parameters(module, tmp_path) == ["module.py:f(a)", "module.py:f(rest)", "module.py:f(extra)"]
