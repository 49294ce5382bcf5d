"""How many episodes ``flownav verify`` flies again to catch a file with some of its episodes changed, and how it
judges episodes flown again on another CPU, where a learned policy's floats (and so its closed-loop episodes)
differ while its rates do not.
"""

from __future__ import annotations

import math

# By default a file with this share of its episodes changed is caught ...
DEFAULT_CHANGED_SHARE = 0.02
# ... with this probability.
DEFAULT_POWER = 0.95
# The level at which re-flown episodes on another CPU are judged to fail more often than the file says.
DISCORDANCE_ALPHA = 0.05


def detection_sample_size(
    total: int, changed_share: float = DEFAULT_CHANGED_SHARE, power: float = DEFAULT_POWER
) -> int:
    """The fewest episodes, drawn without replacement from ``total``, that include at least one changed episode
    with probability ``power`` when ``changed_share`` of them (at least one) were changed: the hypergeometric
    chance of drawing none of them falls to ``1 - power``.

    Raises:
        ValueError: a total below 1, a share outside (0, 1] or a power outside (0, 1).
    """
    if isinstance(total, bool) or not isinstance(total, int) or total < 1:
        raise ValueError(f"the episodes to draw from must be a whole number >= 1, got {total!r}")
    if not 0 < changed_share <= 1:
        raise ValueError(f"--detect must be a share of the episodes in (0, 1], got {changed_share!r}")
    if not 0 < power < 1:
        raise ValueError(f"--power must be a probability in (0, 1), got {power!r}")
    changed = max(1, math.ceil(changed_share * total - 1e-9))
    missed = 1.0
    for drawn in range(total):
        missed *= (total - changed - drawn) / (total - drawn)
        if missed <= 1 - power:
            return drawn + 1
    return total


def detection_power(total: int, changed: int, sample: int) -> float:
    """The chance that ``sample`` episodes drawn without replacement from ``total`` include at least one of
    ``changed`` changed ones."""
    if changed <= 0:
        return 0.0
    return 1.0 - math.comb(total - changed, sample) / math.comb(total, sample)


def discordance_p_value(file_better: int, file_worse: int) -> float:
    """The one-sided exact (binomial, McNemar's) p-value that the file's outcomes are better than the agent's:
    of the episodes that end otherwise when flown again, ``file_better`` succeeded in the file but failed now,
    ``file_worse`` the reverse. An honest file flown on another CPU differs both ways alike."""
    discordant = file_better + file_worse
    if discordant == 0:
        return 1.0
    tail = sum(math.comb(discordant, k) for k in range(file_better, discordant + 1))
    return tail / 2**discordant
