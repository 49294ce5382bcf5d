"""The benchmark suite's task tiers, by suite version: a registered Gymnasium id each. A tier never changes after
results are published under its version; a changed task is a new version with new ids (Gymnasium's rule), and
the old version stays registered and reproducible.

**Suite v2** (:data:`SUITE_VERSION`, the current one) closes the field: capsules stand across the whole region the
drone may fly in (``field_width`` = 2 × ``lateral_bound``), so no lane leads around them. Its tiers are fixed from
physics stated here, before any agent flew them; the only flights before the freeze are feasibility checks of the
privileged references on validation layouts (``results/suite_v2_calibration/``).

| tier | id | course | sensor |
|---|---|---|---|
| ``clean`` | ``FlowNav-v1`` | 1 m/s, 0.12 capsules/m², closed field | perfect rotation and translation |
| ``hard`` | ``FlowNavHard-v1`` | :data:`V2_HARD_COURSE`, closed field | perfect |
| ``noisy`` | ``FlowNavNoisy-v1`` | as clean | :func:`~flownav_env.sensor_specs.flight_stack_sensor` |
| ``hard_noisy`` | ``FlowNavHardNoisy-v1`` | as hard | :func:`~flownav_env.sensor_specs.flight_stack_sensor` |

The physics of v2's courses (:func:`hard_course`): the clean course is the env's defaults (the thesis's 1 m/s,
0.1 m per frame). The hard course doubles the distance per frame (the thesis's variable: 0.2 m, so 2 m/s) and
makes the field's mean free path λ = 1 / (n · 2 (r_capsule + r_hull)), the distance flown between capsules
in the path, the distance of 2 s of flight at that speed (4 m): n = 0.18 capsules/m². These equal v1's hard
course, whose numbers v1 picked by an agent's failure; v2 fixes them by this rule, not by any failure.

**Suite v1** (ids ``...-v0``) is history: its field left a capsule-free lane inside the bounds, and its hard
course and sensor were tuned on agents (``results/suite_v1/``).
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from typing import Any

from flownav_env.sensor_specs import flight_stack_sensor, realistic_sensor
from flownav_env.settings import EnvSettings

# The current suite version: every suite result row carries its version; `--suite-version 1` reproduces v1.
SUITE_VERSION = "2"
SUITE_VERSIONS = ("1", "2")

# v1: chosen on validation layouts by `flownav calibrate-tiers` (results/suite_v1/calibration/calibration.md), the
# one whose best reactive agent failed closest to the middle of 0.20-0.50.
HARD_COURSE: dict[str, float] = {"forward_speed": 2.0, "obstacle_density": 0.18}

# v2's physics (module docstring): the hull's radius is flownav_env.quadrotor's collision radius.
CAPSULE_RADIUS_M = 0.5
HULL_RADIUS_M = 0.2
CLEAN_SPEED_M_S = 1.0
HARD_DISTANCE_PER_FRAME_FACTOR = 2.0
HARD_FREE_PATH_S = 2.0


def hard_course(clean_speed: float = CLEAN_SPEED_M_S) -> dict[str, float]:
    """v2's hard course from its physics: twice the distance per frame, and a field whose mean free path is
    :data:`HARD_FREE_PATH_S` of flight (n = 1 / (λ · 2 (r_capsule + r_hull)), rounded to 0.01 capsules/m²)."""
    speed = clean_speed * HARD_DISTANCE_PER_FRAME_FACTOR
    free_path = speed * HARD_FREE_PATH_S
    density = 1.0 / (free_path * 2.0 * (CAPSULE_RADIUS_M + HULL_RADIUS_M))
    return {"forward_speed": speed, "obstacle_density": round(density, 2)}


# The closed field: capsules across the whole lateral bound (the env's default bound, 6 m each side).
LATERAL_BOUND_M = 6.0
CLOSED_FIELD: dict[str, float] = {"field_width": 2.0 * LATERAL_BOUND_M, "lateral_bound": LATERAL_BOUND_M}
V2_HARD_COURSE: dict[str, float] = hard_course()


@dataclass(frozen=True)
class Tier:
    """One task of the suite: its registered id and the settings it fixes over the env's defaults."""

    name: str
    env_id: str
    course: Mapping[str, Any] = field(default_factory=dict)
    sensor: Mapping[str, Any] = field(default_factory=dict)
    why: str = ""

    @property
    def settings(self) -> dict[str, Any]:
        """Every setting the tier fixes (course, then sensor)."""
        return {**self.course, **self.sensor}


def _v1_tiers() -> dict[str, Tier]:
    return {
        spec.name: spec
        for spec in (
            Tier("clean", "FlowNav-v0", why="the env's defaults, for continuity with the 300-layout history"),
            Tier("hard", "FlowNavHard-v0", course=HARD_COURSE, why="a faster flight through a denser field"),
            Tier(
                "noisy",
                "FlowNavNoisy-v0",
                sensor=realistic_sensor(),
                why="the default course, datasheet errors",
            ),
            Tier(
                "hard_noisy", "FlowNavHardNoisy-v0", course=HARD_COURSE, sensor=realistic_sensor(), why="both"
            ),
        )
    }


def _v2_tiers() -> dict[str, Tier]:
    clean = dict(CLOSED_FIELD)
    hard = {**CLOSED_FIELD, **V2_HARD_COURSE}
    sensor = flight_stack_sensor()
    return {
        spec.name: spec
        for spec in (
            Tier("clean", "FlowNav-v1", course=clean, why="the env's defaults over a closed field"),
            Tier(
                "hard",
                "FlowNavHard-v1",
                course=hard,
                why="twice the distance per frame, a 2-s mean free path",
            ),
            Tier(
                "noisy",
                "FlowNavNoisy-v1",
                course=clean,
                sensor=sensor,
                why="motion told as a flight stack does",
            ),
            Tier(
                "hard_noisy",
                "FlowNavHardNoisy-v1",
                course=hard,
                sensor=sensor,
                why="the hard course, told so",
            ),
        )
    }


TIERS_BY_VERSION: dict[str, dict[str, Tier]] = {"1": _v1_tiers(), "2": _v2_tiers()}
TIERS: dict[str, Tier] = TIERS_BY_VERSION[SUITE_VERSION]
TIER_NAMES = tuple(TIERS)


def check_suite_version(version: str) -> str:
    """``version`` as a suite version string.

    Raises:
        ValueError: not one of :data:`SUITE_VERSIONS`.
    """
    text = str(version)
    if text not in SUITE_VERSIONS:
        raise ValueError(f"suite version must be one of {', '.join(SUITE_VERSIONS)}, got {version!r}")
    return text


def tier(name: str, version: str = SUITE_VERSION) -> Tier:
    """The tier called ``name`` in suite ``version``.

    Raises:
        ValueError: not a tier, or not a suite version; the message lists them.
    """
    tiers = TIERS_BY_VERSION[check_suite_version(version)]
    if name not in tiers:
        close = difflib.get_close_matches(str(name), list(tiers), n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise ValueError(f"tier must be one of {', '.join(tiers)}, got {name!r}{hint}")
    return tiers[name]


def tier_of_env_id(env_id: str) -> tuple[str, Tier] | None:
    """The (suite version, tier) whose registered id is ``env_id``, or None."""
    for version, tiers in TIERS_BY_VERSION.items():
        for spec in tiers.values():
            if spec.env_id == env_id:
                return version, spec
    return None


# The only settings an agent may choose on a tier: each adds an observation key or shapes one (``near_smoothing``;
# the histogram's resolution, ``histogram_sectors`` and ``depth_bin_edges``: the same estimated depths binned finer
# or coarser), so it changes what the agent is shown, never the course it flies or the sensor's errors.
AGENT_OBSERVATION_SETTINGS = (
    "observe_unresolved",
    "observe_counts",
    "observe_nearness",
    "observe_approach",
    "near_smoothing",
    "histogram_sectors",
    "depth_bin_edges",
)
# Setting values that show an agent what no tier's sensor gives: asked for only by an agent declared privileged
# (true depths; the capsule layout and the drone's true state, flownav_env.privileged).
PRIVILEGED_SETTING_VALUES: dict[str, tuple[Any, ...]] = {
    "obs_source": ("oracle", "oracle_valid"),
    "observe_layout": (True,),
}


def tier_value(tier_name: str, setting: str, version: str = SUITE_VERSION) -> Any:
    """The value ``tier_name`` flies ``setting`` with: the tier's own, else the env's default (a tier fixes
    every setting an agent may not choose).

    Raises:
        ValueError: an unknown tier or setting.
    """
    spec = tier(tier_name, version)
    defaults = {item.name: item.default for item in fields(EnvSettings)}
    if setting not in defaults:
        raise ValueError(f"{setting!r} is not a FlowNav env setting")
    return spec.settings.get(setting, defaults[setting])


def privileged_requests(wanted: Mapping[str, object]) -> dict[str, object]:
    """The entries of ``wanted`` (env settings an agent asks for) that would show it privileged data."""
    return {
        key: value
        for key, value in wanted.items()
        if key in PRIVILEGED_SETTING_VALUES and value in PRIVILEGED_SETTING_VALUES[key]
    }


def check_agent_settings(
    agent: str,
    wanted: Mapping[str, object],
    tier_name: str,
    *,
    privileged: bool = False,
    version: str = SUITE_VERSION,
) -> None:
    """Refuse an agent that asks ``tier_name`` for anything but observation keys, so every agent on a tier flies
    the same task. Asking for a setting's tier value is no change and passes; privileged data (true depths)
    passes only for an agent declared ``privileged``.

    Raises:
        ValueError: one line naming the agent, the setting, the value asked for and the tier's value.
    """
    for key, value in wanted.items():
        if key in AGENT_OBSERVATION_SETTINGS:
            continue
        fixed = tier_value(tier_name, key, version)
        if key in privileged_requests({key: value}):
            if privileged:
                continue
            raise ValueError(
                f"agent {agent} asks for {key}={value!r}, privileged data the tier {tier_name} sensor does not "
                "give; only an agent declared privileged (privileged = True) may, and it is listed as a "
                "reference, never ranked"
            )
        if value != fixed:
            raise ValueError(
                f"agent {agent} asks for {key}={value!r}, but tier {tier_name} fixes {key}={fixed!r}: an agent "
                f"may choose only {', '.join(AGENT_OBSERVATION_SETTINGS)}"
            )


def check_flown_settings(
    agent: str,
    flown: Mapping[str, object],
    tier_name: str,
    *,
    privileged: bool = False,
    version: str = SUITE_VERSION,
) -> None:
    """Refuse episodes of ``agent`` recorded on ``tier_name`` with settings ``flown`` (the env kwargs its
    episode records hold) that are not the tier's task: a tier setting missing or changed, or anything else
    that :func:`check_agent_settings` refuses.

    Raises:
        ValueError: one line naming the agent, the tier and the first setting that differs.
    """
    fixed = tier(tier_name, version).settings
    for key, value in fixed.items():
        if key not in flown or flown[key] != value:
            raise ValueError(
                f"agent {agent} was flown on tier {tier_name} with {key}={flown.get(key, 'the default')!r}, but "
                f"the tier fixes {key}={value!r}: these are not the tier's episodes"
            )
    others = {key: value for key, value in flown.items() if key not in fixed}
    check_agent_settings(agent, others, tier_name, privileged=privileged, version=version)
