"""FlowNav's MuJoCo quadcopter-camera environment; importing it registers the Gymnasium ids.

| id                      | layout     | time limit (steps) |
|-------------------------|------------|--------------------|
| ``FlowNav-v0``          | field      | 400                |
| ``FlowNavCorridor-v0``  | corridor   | 400                |
| ``FlowNavSingle-v0``    | single     | 200                |
| ``FlowNavThree-v0``     | three      | 250                |

The benchmark suite's tiers (:mod:`flownav_env.tiers`, one set per suite version) are registered too, field
layouts with 400 steps, each fixing the course and sensor settings its :class:`~flownav_env.tiers.Tier` states:
suite v2's ``FlowNav-v1``, ``FlowNavHard-v1``, ``FlowNavNoisy-v1`` and ``FlowNavHardNoisy-v1`` (a closed field),
and suite v1's ``FlowNavHard-v0``, ``FlowNavNoisy-v0`` and ``FlowNavHardNoisy-v0`` (v1's ``clean`` is
``FlowNav-v0``).

Every constructor kwarg of :class:`FlowNavEnv` is accepted by ``gymnasium.make``: the settings
(:class:`flownav_env.settings.EnvSettings`' fields, or ``settings=`` a whole ``EnvSettings``) and ``render_mode``.
"""

from __future__ import annotations

import os

# Headless by default: the offscreen renderer needs a GL backend picked before mujoco is imported. This is
# the project's one place that picks it; a MUJOCO_GL already set (e.g. osmesa) wins.
DEFAULT_GL_BACKEND = "egl"
os.environ.setdefault("MUJOCO_GL", DEFAULT_GL_BACKEND)

import warnings  # noqa: E402

from gymnasium.envs.registration import register, registry  # noqa: E402  (after the GL backend is set)

# Gymnasium warns that an id is "out of date" when a higher version of its name is registered. FlowNav keeps its
# ``-v0`` ids on purpose: they are suite v1's tasks (history, reproducible) and the env that training configs and
# the history table fly, not a stale version of suite v2's.
V0_OUT_OF_DATE = r".*The environment FlowNav\w*-v0 is out of date"


def ignore_v0_out_of_date() -> None:
    """Silence Gymnasium's "out of date" warning for FlowNav's ``-v0`` ids (again, after a ``simplefilter``)."""
    warnings.filterwarnings("ignore", message=V0_OUT_OF_DATE, category=DeprecationWarning)


ignore_v0_out_of_date()

from estimator import __version__  # noqa: E402
from flownav_env.env import FlowNavEnv  # noqa: E402  (imports mujoco)
from flownav_env.settings import EnvSettings  # noqa: E402
from flownav_env.tiers import TIERS_BY_VERSION  # noqa: E402

ENV_IDS = {
    "FlowNav-v0": ({"layout": "field"}, 400),
    "FlowNavCorridor-v0": ({"layout": "corridor"}, 400),
    "FlowNavSingle-v0": ({"layout": "single"}, 200),
    "FlowNavThree-v0": ({"layout": "three"}, 250),
    **{
        tier.env_id: ({"layout": "field", **tier.settings}, 400)
        for tiers in TIERS_BY_VERSION.values()
        for tier in tiers.values()
        if tier.env_id != "FlowNav-v0"
    },
}


def env_entry_point(
    settings: EnvSettings | None = None, render_mode: str | None = None, **overrides: object
) -> FlowNavEnv:
    """The registered ids' entry point: ``FlowNavEnv(**kwargs)``.

    A function rather than the class, because ``gymnasium.make`` reads an entry point's ``metadata``: on an
    unsupported ``render_mode="human"`` it would build the env in ``"rgb_array"`` and wrap it in
    ``HumanRendering``, which then fails at the first reset asking for pygame. Without ``metadata`` to read it
    passes every kwarg through, and the env rejects a render mode it lacks when it is made.

    Every id passes its ``layout`` as a keyword, which would override the layout of a whole ``settings=``:
    a ``settings.layout`` other than the id's is refused rather than silently replaced.

    Raises:
        ValueError: A kwarg is unknown or outside its range, ``settings.layout`` is not the id's layout, or
            ``render_mode`` is not one of ``FlowNavEnv.metadata["render_modes"]``.
    """
    layout = overrides.get("layout")
    settings_layout = getattr(settings, "layout", layout)
    if layout is not None and settings_layout != layout:
        ids = {id_kwargs["layout"]: env_id for env_id, (id_kwargs, _) in ENV_IDS.items()}
        raise ValueError(
            f"settings.layout is {settings_layout!r} but this env id flies layout {layout!r}: make "
            f"{ids.get(settings_layout, 'the id of that layout')} or pass layout={settings_layout!r} as well"
        )
    return FlowNavEnv(settings, render_mode, **overrides)


for _env_id, (_kwargs, _steps) in ENV_IDS.items():
    if _env_id not in registry:
        register(
            id=_env_id, entry_point="flownav_env:env_entry_point", kwargs=_kwargs, max_episode_steps=_steps
        )

__all__ = ["DEFAULT_GL_BACKEND", "ENV_IDS", "EnvSettings", "FlowNavEnv", "__version__", "env_entry_point"]
