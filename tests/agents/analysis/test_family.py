"""A page's secondary comparisons corrected as one family (Holm)."""

from __future__ import annotations

import pytest

from agents.analysis.family import correct_family
from agents.analysis.paired import Comparison


def _comparison(p: float) -> Comparison:
    return Comparison("a", "b", 0.1, 0.0, 0.2, 0.6, p, p)


def test_holm_across_the_family_names_what_no_longer_separates() -> None:
    family = [
        ("x", _comparison(0.001)),
        ("y", _comparison(0.02)),
        ("z", _comparison(0.04)),
        ("w", _comparison(0.5)),
    ]
    found = correct_family(family)
    # Holm: 0.001 × 4 = 0.004; 0.02 × 3 = 0.06 (stops); so y and z lose it.
    assert (found.tests, found.separated_alone, found.lost, found.kept) == (4, ("x", "y", "z"), ("y", "z"), 1)


def test_an_empty_family_has_nothing_to_lose() -> None:
    found = correct_family([])
    assert (found.tests, found.separated_alone, found.lost, found.kept) == (0, (), (), 0)


def test_a_label_given_twice_is_refused() -> None:
    with pytest.raises(ValueError, match=r"a family names each comparison once; 'x' is given twice"):
        correct_family([("x", _comparison(0.1)), ("x", _comparison(0.2))])
