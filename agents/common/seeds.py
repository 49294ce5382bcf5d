"""The three disjoint ranges of env seeds (layouts) FlowNav draws from, written here and nowhere else.

| range | seeds | used for |
|---|---|---|
| training | ``[0, VALIDATION_SEED_START)`` | the layouts policies learn on, and tuning reactive gains |
| validation | ``[VALIDATION_SEED_START, TEST_SEED_START)`` | every decision: checkpoint choice during training, thresholds, ablations (from ``ABLATION_SEED_START``) |
| test | ``[TEST_SEED_START, ...)`` | only the reported tables (evaluation, sweeps, the demo) |

A layout is a function of its seed alone, so disjoint ranges mean no reported layout was ever trained on or
used to pick anything.
"""

from __future__ import annotations

VALIDATION_SEED_START = 500_000
TEST_SEED_START = 1_000_000

# A training run's own seed k (its config's ``seed``, one of ``flownav train --seeds``) sets where its env workers
# start: worker i first resets on layout k * RUN_SEED_STRIDE + i. With consecutive starts instead, run k's
# second worker would replay run k + 1's first worker layout for layout, and the runs would not be independent.
RUN_SEED_STRIDE = 1_000
MAX_RUN_SEED = VALIDATION_SEED_START // RUN_SEED_STRIDE - 1


# Validation layouts for comparing training runs and ablations (``flownav ablation``): past the starts of the
# checkpoint-selection streams of run seeds below 400 (checkpoint_selection_seed), and before the test range.
ABLATION_SEED_START = 900_000


def training_env_seed(run_seed: int) -> int:
    """The first layout seed of training run ``run_seed``'s env workers (worker i adds i)."""
    return run_seed * RUN_SEED_STRIDE


def checkpoint_selection_seed(run_seed: int) -> int:
    """The first layout seed of training run ``run_seed``'s held-out evaluation env (a validation seed)."""
    return VALIDATION_SEED_START + run_seed * RUN_SEED_STRIDE
