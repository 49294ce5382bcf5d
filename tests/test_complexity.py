"""Every function of the three packages stays simple enough to read top to bottom: cyclomatic complexity at
most :data:`MAX_COMPLEXITY` as radon measures it (``radon cc -s -n C estimator flownav_env agents`` lists
the candidates). A function above it is split along a concern (a helper per step, a table of cases in place
of an if-chain), never squeezed onto fewer lines."""

from __future__ import annotations

from collections.abc import Iterator
from functools import cache
from pathlib import Path

from radon.complexity import cc_visit
from radon.visitors import Class, Function

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("estimator", "flownav_env", "agents")
MAX_COMPLEXITY = 15

# Functions above the limit that are left for now, as "path:qualified name": each lives in a file another
# change was rewriting when the limit was introduced, so splitting it there would have collided with that work.
# Split them when their files are free, and remove each entry with its split (the last test insists).
ALLOWED_ABOVE_LIMIT: frozenset[str] = frozenset()


def _functions(blocks: list[Function | Class]) -> Iterator[tuple[str, int]]:
    """(qualified name, complexity) of every function, method and nested function among ``blocks``: radon
    lists a module's methods beside its functions already, but only their classes hold inner classes."""
    for block in blocks:
        if isinstance(block, Class):
            for inner in block.inner_classes:
                yield from _functions(inner.methods)
        else:
            yield block.fullname, block.complexity
            yield from _closures(block)


def _closures(function: Function) -> Iterator[tuple[str, int]]:
    for closure in function.closures:
        yield f"{function.fullname}.{closure.name}", closure.complexity
        yield from _closures(closure)


@cache
def complexities() -> dict[str, int]:
    """Every function of the packages as "path:qualified name" with its cyclomatic complexity."""
    found = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            where = path.relative_to(ROOT).as_posix()
            for name, complexity in _functions(cc_visit(path.read_text())):
                found[f"{where}:{name}"] = complexity
    return found


def test_every_function_is_at_most_the_complexity_limit() -> None:
    above = {
        name: complexity
        for name, complexity in complexities().items()
        if complexity > MAX_COMPLEXITY and name not in ALLOWED_ABOVE_LIMIT
    }
    listing = "\n".join(f"  {name}: {complexity}" for name, complexity in sorted(above.items()))
    assert not above, f"cyclomatic complexity above {MAX_COMPLEXITY} (split each along a concern):\n{listing}"


def test_allowed_exceptions_are_still_above_the_limit() -> None:
    found = complexities()
    stale = sorted(name for name in ALLOWED_ABOVE_LIMIT if found.get(name, 0) <= MAX_COMPLEXITY)
    assert not stale, f"remove from ALLOWED_ABOVE_LIMIT (gone, or now within the limit): {', '.join(stale)}"
