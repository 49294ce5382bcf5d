"""What suite v2's calibration page states: the tiers' physics and sensor as frozen in code, and the only flights made before
the freeze, the privileged references' feasibility checks on validation layouts (``results/suite_v2_calibration/``).

Nothing here chooses a setting: the tiers are fixed in :mod:`flownav_env.tiers` from stated physics, and a tier
passes its check when each reference fails at most
:data:`~agents.evaluation.suite_check_flights.FEASIBLE_FAILURE` of the checked layouts. The flights are
``flownav evaluate --agent AGENT --env-id ENV --episodes N --seed-start SUITE_V2_CHECK_SEED_START --out
results/suite_v2_calibration/AGENT_ENV.csv``; the noisy tier at other readings of the velocity specification
(the sensitivity table) lies in ``sensitivity/AGENT_ENV_READING_TAU.csv`` beside them.

This module reads the frozen physics from the env package (:func:`frozen_physics`); the flights' summaries, which
read only the committed flights, are :mod:`agents.evaluation.suite_check_flights`, the page
:mod:`agents.pages.calibration_page`. What ``suite.md`` says of the noisy tiers' velocity reading, from the same
sensitivity flights, is :mod:`agents.pages.velocity_reading`'s.
"""

from __future__ import annotations

from agents.evaluation.suite_check_flights import FrozenPhysics, TierFacts
from flownav_env import sensor_specs
from flownav_env.tiers import CAPSULE_RADIUS_M, HARD_FREE_PATH_S, HULL_RADIUS_M, TIER_NAMES, tier

CHECKED_VERSION = "2"


def frozen_physics(version: str = CHECKED_VERSION) -> FrozenPhysics:
    """Suite ``version``'s tiers and the sensor's velocity readings, as :mod:`flownav_env` freezes them."""
    tiers = tuple(
        TierFacts(name, spec.env_id, spec.why, spec.settings)
        for name in TIER_NAMES
        for spec in (tier(name, version),)
    )
    return FrozenPhysics(
        tiers=tiers,
        capsule_radius_m=CAPSULE_RADIUS_M,
        hull_radius_m=HULL_RADIUS_M,
        hard_free_path_s=HARD_FREE_PATH_S,
        velocity_accuracy_m_s=sensor_specs.VELOCITY_ACCURACY_M_S,
        velocity_readings=dict(sensor_specs.VELOCITY_READINGS),
        flight_stack_reading=sensor_specs.FLIGHT_STACK_READING,
        velocity_correlation_s=sensor_specs.VELOCITY_CORRELATION_S,
        velocity_correlation_readings_s=tuple(sensor_specs.VELOCITY_CORRELATION_READINGS_S),
    )
