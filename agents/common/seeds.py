"""The three disjoint ranges of env seeds (layouts) FlowNav draws from, written here and nowhere else.

| range | seeds | used for |
|---|---|---|
| training | ``[0, VALIDATION_SEED_START)`` | the layouts policies learn on, and tuning reactive gains |
| validation | ``[VALIDATION_SEED_START, TEST_SEED_START)`` | every decision: checkpoint choice during training, thresholds, ablations |
| test | ``[TEST_SEED_START, ...)`` | only the reported tables (evaluation, sweeps, the demo) |

A layout is a function of its seed alone, so disjoint ranges mean no reported layout was ever trained on or
used to pick anything.
"""

from __future__ import annotations

VALIDATION_SEED_START = 500_000
TEST_SEED_START = 1_000_000


def seed_range(seed: int) -> str:
    """``"training"``, ``"validation"`` or ``"test"``: the range ``seed`` belongs to.

    Raises:
        ValueError: a negative seed (no range holds it).
    """
    if seed < 0:
        raise ValueError(f"seed must be >= 0, got {seed}")
    if seed < VALIDATION_SEED_START:
        return "training"
    return "validation" if seed < TEST_SEED_START else "test"
