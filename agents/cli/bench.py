"""Performance benchmarks that write their tables, CSVs and plots to ``--out``: by default ``{scratch_out}``, a
scratch folder; ``--out results`` replaces the committed report.

``flownav bench estimator``: thesis Table 3 on a rendered 640×480 flight (points and ms per stage against the
FAST threshold, against bare OpenCV FAST + LK).

``flownav bench env``: steps per second of FlowNav-v0 per camera resolution against a bare MuJoCo physics +
render loop of the same scene, with the per-stage breakdown of a step.

``flownav bench recipe``: minutes per training seed of whole recipes, measured side by side.

``flownav bench yield``: valid depths per frame and their accuracy per estimator setting in FlowNav flights.

``flownav bench isolation``: the cost per env step of flying an outside agent in a process of its own, against
the same agent loaded in the scoring process.

Timings are wall-clock on whatever machine runs them; every measurement is taken as a ratio against a
baseline run in the same process, alternated with it, and quoted as a median over repeats, so that a machine
shared with other jobs shifts both sides alike.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path

from agents.cli.arguments import add_seed_start_argument

# Runs land in a scratch folder unless asked: the committed reports in results/ are replaced only on purpose.
SCRATCH_OUT = Path("runs") / "bench"
if __doc__:  # None under python -OO
    __doc__ = __doc__.replace("{scratch_out}", SCRATCH_OUT.as_posix())

HELP = (
    "performance benchmarks: `bench estimator` (thesis Table 3), `bench env` (steps/s per resolution), "
    "`bench recipe` (minutes per training seed of whole recipes), `bench yield` (valid depths per setting) and "
    "`bench isolation` (what an outside agent's own process costs a step)"
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register one sub-subcommand per benchmark and their options."""
    targets = parser.add_subparsers(dest="target", required=True, metavar="TARGET")

    estimator = targets.add_parser(
        "estimator",
        help="thesis Table 3: points and ms per stage vs FAST threshold on a 640x480 flight",
    )
    estimator.add_argument("--frames", type=int, default=40, help="frame pairs of the flight (default 40)")
    estimator.add_argument(
        "--repeats", type=int, default=3, help="timed passes per configuration (default 3)"
    )
    estimator.add_argument(
        "--thresholds",
        type=_int_list,
        default=(50, 40, 30, 20, 15, 10, 5, 3, 1),
        help="comma-separated FAST thresholds (default 50,40,30,20,15,10,5,3,1)",
    )
    estimator.add_argument("--width", type=int, default=640, help="camera width in px (default 640)")
    estimator.add_argument("--height", type=int, default=480, help="camera height in px (default 480)")
    estimator.add_argument("--layout", default="three", help="env layout of the flight (default three)")
    add_seed_start_argument(estimator, 0, "layout seed of the flight (default 0)")
    _add_output_options(estimator)

    env = targets.add_parser(
        "env", help="steps/s per camera resolution vs a bare MuJoCo render + physics loop"
    )
    env.add_argument(
        "--resolutions",
        type=_resolution_list,
        default=((64, 48), (96, 72), (128, 96), (160, 120), (240, 180), (320, 240)),
        help="comma-separated WxH candidates (default 64x48,96x72,128x96,160x120,240x180,320x240)",
    )
    env.add_argument("--steps", type=int, default=100, help="env steps per timed block (default 100)")
    env.add_argument("--repeats", type=int, default=5, help="timed blocks per configuration (default 5)")
    add_seed_start_argument(env, 0, "layout seed of the first episode (default 0)")
    _add_output_options(env)

    recipe = targets.add_parser(
        "recipe", help="minutes per training seed of whole recipes (all their stages), side by side"
    )
    recipe.add_argument(
        "--recipe",
        action="append",
        required=True,
        metavar="[NAME=]STAGE.yaml[,STAGE.yaml...]",
        help="a recipe: its stage configs in training order; give two or more, the first is the reference",
    )
    recipe.add_argument("--rollouts", type=int, default=2, help="timed PPO rollouts per stage (default 2)")
    recipe.add_argument("--repeats", type=int, default=3, help="alternated blocks per recipe (default 3)")
    recipe.add_argument(
        "--ablation-dir",
        type=Path,
        default=Path("results") / "ablation",
        help="flownav ablation's --out, for each recipe's validation quality (default results/ablation)",
    )
    _add_output_options(recipe)

    depth_yield = targets.add_parser(
        "yield",
        help="valid depths per frame and their accuracy per estimator setting, in FlowNav flights",
    )
    depth_yield.add_argument(
        "--frames", type=_int_list, default=(1, 2, 4, 8), help="baseline_frames variants (default 1,2,4,8)"
    )
    depth_yield.add_argument(
        "--fast-thresholds", type=_int_list, default=(7, 5), help="FAST threshold variants (default 7,5)"
    )
    depth_yield.add_argument(
        "--setting",
        action="append",
        default=None,
        metavar="KEY=VALUE",
        help="one more variant per use, an estimator setting (default: fb_max_error_px=1.0, "
        "min_parallax_px=0.5, max_epipolar_error_px=1.5, max_lk_error=8, fast_threshold=5;baseline_frames=4)",
    )
    depth_yield.add_argument(
        "--flights", type=int, default=6, help="scripted flights per variant (default 6)"
    )
    depth_yield.add_argument("--steps", type=int, default=120, help="steps per flight (default 120)")
    _add_output_options(depth_yield)

    isolation = targets.add_parser(
        "isolation", help="the cost per step of an outside agent in its own process, against in-process"
    )
    isolation.add_argument(
        "--agent",
        help="the outside agent, file.py:factory (default: tests/examples/open_gap_agent.py:make_agent)",
    )
    isolation.add_argument("--steps", type=int, default=100, help="env steps per timed block (default 100)")
    isolation.add_argument("--repeats", type=int, default=5, help="alternated blocks per side (default 5)")
    _add_output_options(isolation)


def run(args: argparse.Namespace) -> int:
    """Run the chosen benchmark and write its files; returns the process exit code."""
    for path in _BENCHMARKS[args.target](args):
        print(f"wrote {path}")
    return 0


# Each benchmark imports its study on use: `flownav --help` imports every subcommand module and must stay quick.


def _estimator(args: argparse.Namespace) -> list[Path]:
    from agents.studies.perf.estimator_speed_report import run_estimator_benchmark

    return run_estimator_benchmark(
        frames=args.frames,
        thresholds=args.thresholds,
        repeats=args.repeats,
        width=args.width,
        height=args.height,
        layout=args.layout,
        seed=args.seed_start,
        out_dir=args.out,
        progress=not args.no_progress,
    )


def _env(args: argparse.Namespace) -> list[Path]:
    from agents.studies.perf.env_speed_report import run_env_benchmark

    return run_env_benchmark(
        resolutions=args.resolutions,
        steps=args.steps,
        repeats=args.repeats,
        seed=args.seed_start,
        out_dir=args.out,
        progress=not args.no_progress,
    )


def _recipe(args: argparse.Namespace) -> list[Path]:
    from agents.policies.teachers import make_teacher
    from agents.studies.perf.recipe_speed_report import run_recipe_benchmark

    return run_recipe_benchmark(
        args.recipe,
        args.rollouts,
        args.repeats,
        args.out,
        make_teacher=make_teacher,
        ablation_dir=args.ablation_dir,
        progress=not args.no_progress,
    )


def _yield(args: argparse.Namespace) -> list[Path]:
    from agents.studies.perf.depth_yield import DEFAULT_SETTINGS, run_depth_yield

    return run_depth_yield(
        args.frames,
        args.fast_thresholds,
        DEFAULT_SETTINGS if args.setting is None else args.setting,
        args.flights,
        args.steps,
        args.out,
        progress=not args.no_progress,
    )


def _isolation(args: argparse.Namespace) -> list[Path]:
    from agents.studies.perf.isolation_cost import DEFAULT_AGENT, run_isolation_benchmark

    return run_isolation_benchmark(
        args.agent or DEFAULT_AGENT, steps=args.steps, repeats=args.repeats, out_dir=args.out
    )


# The sub-subcommand each benchmark answers to, as registered in add_arguments.
_BENCHMARKS: dict[str, Callable[[argparse.Namespace], list[Path]]] = {
    "estimator": _estimator,
    "env": _env,
    "recipe": _recipe,
    "yield": _yield,
    "isolation": _isolation,
}


def _add_output_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--out",
        type=Path,
        default=SCRATCH_OUT,
        help=f"output folder (default {SCRATCH_OUT}, a scratch folder; --out results replaces the committed report)",
    )
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bars")


def _int_list(text: str) -> tuple[int, ...]:
    try:
        values = tuple(int(part) for part in text.split(",") if part.strip())
    except ValueError as error:
        raise argparse.ArgumentTypeError(f"expected comma-separated integers, got {text!r}") from error
    if not values:
        raise argparse.ArgumentTypeError("expected at least one integer")
    return values


def _resolution_list(text: str) -> tuple[tuple[int, int], ...]:
    resolutions = []
    for part in text.split(","):
        width, sep, height = part.strip().lower().partition("x")
        if not sep or not width.isdigit() or not height.isdigit():
            raise argparse.ArgumentTypeError(f"expected WxH resolutions like 160x120, got {part!r}")
        resolutions.append((int(width), int(height)))
    return tuple(resolutions)
