"""A page's secondary comparisons as one family: each is read on its own 95 % interval where the page shows it,
and this says which of those that separate alone still separate once Holm's correction runs across all of them
(a page that makes 30 paired comparisons finds one or two "significant" by chance alone)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from agents.analysis.paired import SIGNIFICANCE, Comparison, holm


@dataclass(frozen=True)
class FamilyCorrection:
    """``tests`` comparisons corrected together: the labels of those whose own p-value separates them
    (``separated_alone``) and, of those, the labels Holm across the family no longer separates (``lost``)."""

    tests: int
    separated_alone: tuple[str, ...]
    lost: tuple[str, ...]

    @property
    def kept(self) -> int:
        """How many comparisons still separate under the family's correction."""
        return len(self.separated_alone) - len(self.lost)


def correct_family(comparisons: Sequence[tuple[str, Comparison]]) -> FamilyCorrection:
    """Holm's correction across ``comparisons`` (label, comparison), in the order given.

    Raises:
        ValueError: two comparisons with the same label (a family names each test once).
    """
    labels = [label for label, _ in comparisons]
    if len(set(labels)) != len(labels):
        repeated = next(label for label in labels if labels.count(label) > 1)
        raise ValueError(f"a family names each comparison once; {repeated!r} is given twice")
    corrected = holm([comparison.p_value for _, comparison in comparisons])
    alone = [
        (label, c.p_value < SIGNIFICANCE, p) for (label, c), p in zip(comparisons, corrected, strict=True)
    ]
    return FamilyCorrection(
        tests=len(comparisons),
        separated_alone=tuple(label for label, separated, _ in alone if separated),
        lost=tuple(label for label, separated, p in alone if separated and p >= SIGNIFICANCE),
    )
