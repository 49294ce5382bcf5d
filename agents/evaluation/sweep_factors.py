"""What a sweep may vary, and the env settings each (factor, level) cell flies with.

Most factors are one env setting, flown at the level on top of the sweep's base settings. Two are the noisy
tiers' velocity error (:func:`flownav_env.sensor_specs.flight_stack_sensor`), a noise floor correlated in time,
which takes two settings at once; each varies one of them and holds the other at the tier's reading:

- ``velocity_error_m_s``: the velocity error's σ (m/s per axis), at the tier's correlation time;
- ``velocity_correlation_s``: its correlation time τ (s; 0 is white noise), at the tier's σ.

The sweep's own ``translation_noise_m`` stays the white per-frame floor it was on ``FlowNav-v0``, so its levels
keep comparing with that sweep's.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping

from flownav_env.sensor_specs import (
    FLIGHT_STACK_READING,
    VELOCITY_CORRELATION_S,
    VELOCITY_READINGS,
    translation_noise_m,
)
from flownav_env.settings_check import check_setting

# Factors that are one env setting of the same name.
SETTING_FACTORS = (
    "rotation_error",
    "translation_error",
    "attitude_jitter_deg",
    "brightness",
    "forward_speed",
    "obstacle_density",
    "rotation_bias",
    "translation_bias",
    "rotation_drift",
    "translation_drift",
    "rotation_noise_deg",
    "translation_noise_m",
    "depth_noise",
    "depth_outliers",
    "depth_dropout",
)
# The noisy tiers' velocity error at its reading: σ (m/s) and correlation time (s).
TIER_VELOCITY_SIGMA_M_S = VELOCITY_READINGS[FLIGHT_STACK_READING][1]
TIER_VELOCITY_CORRELATION_S = VELOCITY_CORRELATION_S


def _velocity_error(sigma_m_s: float) -> dict[str, float]:
    return {
        "translation_noise_m": translation_noise_m(sigma_m_s),
        "translation_noise_correlation_s": TIER_VELOCITY_CORRELATION_S,
    }


def _velocity_correlation(correlation_s: float) -> dict[str, float]:
    return {
        "translation_noise_m": translation_noise_m(TIER_VELOCITY_SIGMA_M_S),
        "translation_noise_correlation_s": correlation_s,
    }


# Factors that set several env settings: the level's settings.
COMPOSITE_FACTORS: Mapping[str, Callable[[float], dict[str, float]]] = {
    "velocity_error_m_s": _velocity_error,
    "velocity_correlation_s": _velocity_correlation,
}
SWEEP_FACTORS = SETTING_FACTORS + tuple(COMPOSITE_FACTORS)
# Where a composite factor's tolerance scan starts: the level that does nothing. The velocity error does nothing at
# σ = 0; its correlation time is flown at the tier's σ, so no τ does nothing and every level is scanned on one
# side, from the smallest (a white error, τ = 0, is already an error).
COMPOSITE_NEUTRAL: Mapping[str, float] = {"velocity_error_m_s": 0.0, "velocity_correlation_s": -math.inf}


def factor_settings(factor: str, level: float) -> dict[str, float]:
    """The env settings of ``factor`` at ``level`` (without the sweep's base settings).

    Raises:
        ValueError: an unknown factor, or a level outside the allowed range of a setting it sets (the message
            names the setting and the range).
    """
    if factor in COMPOSITE_FACTORS:
        if isinstance(level, bool) or not isinstance(level, (int, float)) or level < 0:
            raise ValueError(f"{factor} must be a number >= 0, got {level!r}")
        settings = COMPOSITE_FACTORS[factor](float(level))
    elif factor in SETTING_FACTORS:
        settings = {factor: level}
    else:
        raise ValueError(f"not a sweep factor: {factor!r} (allowed: {', '.join(SWEEP_FACTORS)})")
    for name, value in settings.items():
        check_setting(name, value)
    return settings
