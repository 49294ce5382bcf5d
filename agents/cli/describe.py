"""``flownav describe [--tiers TIER]``: what an agent is given and must return on a tier of the suite.

Read from the env itself, not typed here: a real env of the tier is made (with every optional observation key
on) and its observation and action spaces give each key's shape, dtype and range; the meaning of each key and
each action, and the action's units, come from the env's documented tables (``help(flownav_env.FlowNavEnv)``),
with the scales resolved to the tier's values. An agent is anything with stable-baselines3's ``predict``;
score it with ``flownav score --agent file.py:make_agent``.
"""

from __future__ import annotations

import argparse
import itertools
import re
import sys
from dataclasses import fields, replace
from typing import TypeVar

import gymnasium as gym
from gymnasium import spaces

import flownav_env
from agents.cli.arguments import add_tier_argument, tier_name_of
from agents.cli.help_text import plain_text
from agents.common.tables import markdown_table
from agents.policies.external import PREDICT_SIGNATURE
from agents.policies.observation_keys import OBSERVATION_KEY_SETTINGS
from flownav_env.settings import EnvSettings
from flownav_env.tiers import AGENT_OBSERVATION_SETTINGS, TIER_NAMES, tier

Space = TypeVar("Space", bound=gym.Space)

HELP = "the agent contract of a tier: observation keys, shapes and meaning; the action and its units; predict"

# The headings of FlowNavEnv's docstring whose first table is read here.
OBSERVATION_HEADING = "## Observation Space"
STATE_HEADING = "``state`` (clipped"
ACTION_HEADING = "## Action Space"
SIGNS_HEADING = "## Signs"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_tier_argument(
        parser, TIER_NAMES[0], f"one of {', '.join(TIER_NAMES)}, or its Gymnasium id (default: %(default)s)"
    )
    # The first spelling, `flownav describe hard`, kept: said as --tiers when used.
    parser.add_argument("tier", nargs="?", help=argparse.SUPPRESS)


def run(args: argparse.Namespace) -> int:
    tier_text = args.tiers
    if args.tier is not None:
        print(
            f"flownav describe: a tier without --tiers is an old spelling; use --tiers {args.tier}",
            file=sys.stderr,
        )
        tier_text = args.tier
    print("\n".join(describe_tier(tier_name_of(tier_text))))
    return 0


def describe_tier(tier_name: str) -> list[str]:
    """The agent contract of tier ``tier_name`` as lines of text, from a real env of the tier.

    Raises:
        ValueError: not a tier; the message lists them.
    """
    spec = tier(tier_name)
    every_key = dict.fromkeys(OBSERVATION_KEY_SETTINGS.values(), True)
    env = gym.make(spec.env_id, **spec.settings, **every_key)
    try:
        settings: EnvSettings = env.get_wrapper_attr("settings")
        observation_space = _space(env.observation_space, spaces.Dict)
        action_space = _space(env.action_space, spaces.Box)
    finally:
        env.close()
    doc = flownav_env.FlowNavEnv.__doc__ or ""
    fixed = ", ".join(f"{key}={value}" for key, value in spec.settings.items()) or "none (the env's defaults)"
    return [
        f"Tier {spec.name} ({spec.env_id}): {spec.why}. Settings it fixes: {fixed}.",
        "",
        "An agent is any object with stable-baselines3's",
        f"    {PREDICT_SIGNATURE}",
        f"called once per step ({settings.frame_rate:g} steps per second of flight) with deterministic=True; "
        "state is what the agent returned last (None at the first step), episode_start is [True] at an "
        "episode's first step. An agent without memory returns (action, None).",
        "",
        "Observation: a dict of arrays. Optional keys come only where the agent asks for them with "
        'env_settings = {"<setting>": True} on the object.',
        "",
        _observation_table(observation_space, _doc_table(doc, OBSERVATION_HEADING), OBSERVATION_KEY_SETTINGS),
        "",
        f"depth_histogram's bins on this tier: {_bins_text(settings.depth_bin_edges)}; sectors "
        f"{settings.histogram_sectors[0]} rows by {settings.histogram_sectors[1]} columns of the image. The "
        'resolution is the agent\'s to choose: ask for another with env_settings = {"histogram_sectors": '
        '[rows, cols], "depth_bin_edges": [...]} (the same depths binned otherwise; the task stays the tier\'s).',
        "",
        "The state entries:",
        "",
        _entries_table(_space(observation_space["state"], spaces.Box), _doc_table(doc, STATE_HEADING)),
        "",
        f"Action: {_space_text(action_space)}. {_doc_paragraph(doc, ACTION_HEADING)} On this tier "
        f"forward_speed is {settings.forward_speed:g} m/s.",
        "",
        _action_table(action_space, _doc_table(doc, ACTION_HEADING), settings),
        "",
        f"Signs. {_doc_paragraph(doc, SIGNS_HEADING)}",
        "",
        markdown_table(["quantity", "positive means"], _doc_table(doc, SIGNS_HEADING)),
        "",
        f"Every setting of tier {spec.name} (* fixed by the tier; the rest are the env's defaults, and an agent "
        f"may ask only for {', '.join(AGENT_OBSERVATION_SETTINGS)}):",
        "",
        _settings_table(
            replace(settings, **{key: getattr(EnvSettings(), key) for key in every_key}), spec.settings
        ),
        "",
        f"The env in full: help(flownav_env.FlowNavEnv). Score an agent on this tier: flownav score --agent "
        f"my_agent.py:make_agent --tiers {spec.name}.",
    ]


def _bins_text(edges: tuple[float, ...]) -> str:
    """``depth_bin_edges`` as the bins they make: ``[0, 1), [1, 2), ..., [8, 13) and beyond (m)``."""
    bins = [f"[{low:g}, {high:g})" for low, high in itertools.pairwise(edges)]
    return f"{len(bins)} bins of depth (m), depth_bin_edges {list(edges)}: {', '.join(bins)}, the last one also counting what lies beyond {edges[-1]:g} m"


def _settings_table(settings: EnvSettings, fixed: dict[str, object]) -> str:
    """Every env setting with its value on the tier, the ones the tier fixes starred."""
    rows = [
        [f"{item.name}{' *' if item.name in fixed else ''}", getattr(settings, item.name)]
        for item in fields(settings)
    ]
    return markdown_table(["setting", "value"], rows)


def _doc_table(doc: str, heading: str) -> list[list[str]]:
    """The body rows of the first markdown table after ``heading`` in ``doc``, cells as plain text.

    Raises:
        ValueError: the docstring has no such heading or table (the env's documentation changed shape).
    """
    start = doc.find(heading)
    lines = doc[start:].splitlines() if start >= 0 else []
    table = []
    for line in (line.strip() for line in lines[1:]):
        if line.startswith("|"):
            table.append([plain_text(cell.strip()) for cell in line.strip("|").split("|")])
        elif table:
            break
    if len(table) < 3:
        raise ValueError(
            f"FlowNavEnv's docstring has no table after {heading!r}; flownav describe reads it there"
        )
    return table[2:]  # past the header and its separator


def _doc_paragraph(doc: str, heading: str) -> str:
    """The first paragraph after ``heading`` in ``doc`` as one line of plain text."""
    text = doc[doc.find(heading) + len(heading) :] if heading in doc else ""
    return plain_text(" ".join(text.strip().split("\n\n", 1)[0].split()))


def _space(space: gym.Space, kind: type[Space]) -> Space:
    """``space`` as the ``kind`` of space the env documents it as.

    Raises:
        TypeError: the env's space is of another kind (its documentation changed shape).
    """
    if not isinstance(space, kind):
        raise TypeError(f"expected a {kind.__name__} space, the env has {space!r}")
    return space


def _bounds(space: spaces.Box) -> str:
    low, high = float(space.low.min()), float(space.high.max())
    if (space.low == low).all() and (space.high == high).all():
        return f"[{low:g}, {high:g}]"
    return "per entry, below"


def _space_text(space: spaces.Box) -> str:
    return f"{space.dtype} array of shape {space.shape}, each value in {_bounds(space)}"


def _observation_table(space: spaces.Dict, documented: list[list[str]], optional: dict[str, str]) -> str:
    meanings = {row[0]: row[-1] for row in documented}
    rows = []
    # The keys every agent gets first, then the ones it asks for.
    for key, entry in sorted(space.spaces.items(), key=lambda item: (item[0] in optional, item[0])):
        box = _space(entry, spaces.Box)
        meaning = meanings.get(key, "(not in the env's table)")
        if key in optional:
            meaning = f"[env_settings {optional[key]}=True] {re.sub(r'^only with [^:]*: ', '', meaning)}"
        rows.append([key, box.shape, box.dtype, _bounds(box), meaning])
    return markdown_table(["key", "shape", "dtype", "range", "meaning"], rows)


def _entries_table(space: spaces.Box, documented: list[list[str]]) -> str:
    rows = [
        [index, row[1], f"{space.low[index]:g}", f"{space.high[index]:g}", row[-1]]
        for index, row in enumerate(documented)
    ]
    return markdown_table(["index", "observation", "min", "max", "unit"], rows)


def _action_table(space: spaces.Box, documented: list[list[str]], settings: EnvSettings) -> str:
    """The action's entries with the bounds of ``space`` and each scale's setting resolved to the tier's value."""
    names = {item.name for item in fields(settings)}
    rows = []
    for index, row in enumerate(documented):
        scale = row[4]
        for name in (word for word in re.findall(r"\w+", scale) if word in names):
            scale += f" = ±{getattr(settings, name):g}"
        rows.append([index, row[1], f"{space.low[index]:g}", f"{space.high[index]:g}", scale, row[5]])
    return markdown_table(["index", "action", "min", "max", "1 means", "unit"], rows)
