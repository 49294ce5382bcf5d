"""``flownav train``: PPO on FlowNav from a YAML config (see :mod:`agents.training.ppo`).

A run writes only under ``<runs-dir>/<name>/``: policy, config copy, record, evaluations, learning curve,
checkpoints and TensorBoard logs. Shipping it to the policies folder that the benchmark flies
(``results/policies/``) is deliberate: ``--ship`` at the end of training, or ``--ship-only`` for a finished run.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import shlex
import sys
from pathlib import Path

from agents.cli.arguments import add_tier_argument, tier_name_of
from agents.common.folders import check_writable_folder
from agents.common.locations import POLICIES_DIR
from agents.common.yaml_config import load_config
from agents.training.outputs import RunFiles
from agents.training.parking import PARKED_DIR
from agents.training.train_config import TrainConfig, for_tier, override
from flownav_env.settings_check import check_env_kwargs

HELP = "train a PPO policy from a YAML config into runs/<name>/ (resumable; --ship to publish it)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", required=True, help="training config YAML, e.g. configs/ppo_flow.yaml")
    parser.add_argument(
        "--resume",
        action="store_true",
        help="continue from the newest readable checkpoint of the run. Checkpoints are loaded with "
        "PPO.load, which unpickles them and so can run code: resume only runs you made yourself",
    )
    parser.add_argument(
        "--runs-dir", default="runs", help="the run's outputs go to RUNS_DIR/<name>/ (default runs/)"
    )
    parser.add_argument(
        "--ship",
        action="store_true",
        help="after training (unless interrupted), copy the run's policy, config, record, evaluations and "
        "curve to --ship-to and update its MANIFEST.sha256",
    )
    parser.add_argument(
        "--ship-only",
        action="store_true",
        help="do not train: ship the finished run of --config to --ship-to",
    )
    parser.add_argument(
        "--ship-to", default=str(POLICIES_DIR), help=f"policies folder to ship to (default {POLICIES_DIR})"
    )
    parser.add_argument(
        "--seeds",
        help="train several independent seeds of the config, e.g. 0-4 or 0,2,5: each into "
        "RUNS_DIR/<name>/seed_<k>/ (shipped as <ship-to>/<name>/seed_<k>.zip), resuming unfinished seeds and "
        "skipping finished ones",
    )
    parser.add_argument(
        "--backend",
        choices=("local", "ray"),
        default="local",
        help="with --seeds: train the seeds in turn here (local) or as parallel Ray tasks of n_envs CPUs each",
    )
    parser.add_argument(
        "--address", help="with --backend ray: the Ray cluster's address (default: start one)"
    )
    parser.add_argument(
        "--parallel",
        type=int,
        default=1,
        help="with --seeds and the local backend: train this many seeds at a time, each in one process that "
        "steps its own envs (same rollouts; on a small machine more steps per second than one at a time). "
        "Default 1",
    )
    parser.add_argument(
        "--park",
        action="store_true",
        help="with --seeds, do not train: copy each unfinished seed's resume state (newest checkpoint, "
        "evaluations, best model, record) to --parked-dir to commit, so a new checkout resumes it "
        "(runs/ is not committed); --seeds restores and resumes parked seeds by itself",
    )
    parser.add_argument(
        "--parked-dir",
        default=str(PARKED_DIR),
        help=f"where seeds are parked and restored from (default {PARKED_DIR})",
    )
    add_tier_argument(
        parser,
        None,
        "with a recipe for every tier ('per_tier: true'): the suite tier to train on (clean, hard, noisy, "
        "hard_noisy, or its env id); the run flies that tier's id and is named <name>_<tier>",
    )
    parser.add_argument("--total-timesteps", type=int, help="override the config's total_timesteps")
    parser.add_argument("--max-minutes", type=float, help="override the config's wall-clock budget")


def run(args: argparse.Namespace) -> int:
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.training.ppo import train

    config_path = Path(args.config)
    config = load_config(config_path, TrainConfig)
    config = for_tier(config, args.tiers and tier_name_of(args.tiers), str(config_path))
    _check_mode_options(args)
    if args.tiers and args.seeds is None:
        # A seed's own config file, written into its run folder, holds the tier's id and name.
        raise ValueError(f"--tiers {args.tiers} trains with --seeds (e.g. --seeds 0): give it")
    if args.ship_only:
        _ship_only(args, config.name)
        return 0
    override(config, "total_timesteps", args.total_timesteps, "--total-timesteps")
    override(config, "max_minutes", args.max_minutes, "--max-minutes")
    check_env_kwargs(config.env, str(config_path))
    if config.imitation.teacher:
        # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
        from agents.policies.teachers import check_teacher

        check_teacher(config.imitation.teacher, config.env, str(config_path), config.imitation.teacher_params)
    if args.seeds is None and (args.backend != "local" or args.address is not None or args.parallel != 1):
        raise ValueError("--backend, --address and --parallel apply to --seeds runs only")
    _check_output_folders(args, config.name)
    if args.seeds is not None:
        return _train_seeds(args, config, config_path)
    command = command_line(args)
    files = RunFiles.of(Path(args.runs_dir), config.name)
    train(
        config,
        config_path=config_path,
        resume=args.resume,
        runs_dir=Path(args.runs_dir),
        ship_to=Path(args.ship_to) if args.ship else None,
        command=command,
        make_teacher=_teacher_maker(config),
    )
    _raise_if_interrupted(files, command if args.resume else f"{command} --resume")
    return 0


def _check_mode_options(args: argparse.Namespace) -> None:
    """Refuse options that contradict the mode chosen (several seeds, parking, shipping only)."""
    if args.seeds is not None and args.resume:
        raise ValueError("--seeds always resumes unfinished seeds: drop --resume")
    if args.park and (args.seeds is None or args.ship or args.ship_only):
        raise ValueError("--park takes --seeds and no shipping options: it copies unfinished seeds aside")


def _ship_only(args: argparse.Namespace, name: str) -> None:
    """``--ship-only``: ship the finished run of config ``name``, or each of its ``--seeds``, training nothing."""
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.training.shipping import ship_run

    if args.seeds is not None:
        # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
        from agents.training.multiseed import parse_seeds

        for seed in parse_seeds(args.seeds):
            ship_run(RunFiles.of_seed(Path(args.runs_dir), name, seed), Path(args.ship_to) / name)
        return
    if args.resume or args.ship or args.total_timesteps is not None or args.max_minutes is not None:
        raise ValueError("--ship-only ships a finished run: it takes no training options")
    ship_run(RunFiles.of(Path(args.runs_dir), name), Path(args.ship_to))


def _teacher_maker(config):
    """What builds the config's teacher (the rules live above the training layer), or None without one."""
    if not config.imitation.teacher:
        return None
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.policies.teachers import make_teacher

    return make_teacher


def command_line(args: argparse.Namespace) -> str:
    """The ``flownav train`` command line that gave ``args``, for the training record: this process's own
    arguments as typed when they are the ones parsed, else (``main`` called from code) every option that
    differs from its default.

    Args:
        args: the parsed arguments of ``flownav train``.

    Returns:
        The command, quoted for a POSIX shell.
    """
    parser = argparse.ArgumentParser(add_help=False)
    add_arguments(parser)
    typed = sys.argv[1:]
    if typed[:1] == ["train"]:
        # A parse error here only means the process was started otherwise: keep its message off the terminal.
        with contextlib.redirect_stderr(io.StringIO()), contextlib.suppress(SystemExit):
            parsed, extra = parser.parse_known_args(typed[1:])
            if not extra and all(getattr(args, k, None) == v for k, v in vars(parsed).items()):
                return shlex.join(["flownav", *typed])
    defaults = vars(parser.parse_args(["--config", args.config]))
    words = ["flownav", "train", "--config", str(args.config)]
    for name, default in defaults.items():
        value = getattr(args, name, default)
        if name == "config" or value == default:
            continue
        option = "--" + name.replace("_", "-")
        words += [option] if value is True else [option, str(value)]
    return shlex.join(words)


def _check_output_folders(args: argparse.Namespace, name: str) -> None:
    """Every folder the run writes to takes files, before any env is built.

    Raises:
        ValueError: a folder that cannot be created or written, named with its option.
    """

    check_writable_folder(Path(args.runs_dir) / name, "--runs-dir")
    if args.ship:
        ship_to = Path(args.ship_to) / name if args.seeds is not None else Path(args.ship_to)
        check_writable_folder(ship_to, "--ship-to")
    if args.park:
        check_writable_folder(Path(args.parked_dir), "--parked-dir")


def _raise_if_interrupted(files: RunFiles, resume_command: str) -> None:
    """After a run: raise ``KeyboardInterrupt`` saying where the run stopped and how to resume, when its last
    session was stopped by Ctrl-C or SIGTERM (``flownav`` then exits 130, as for every interrupted command).

    Raises:
        KeyboardInterrupt: the run's last session was interrupted.
    """
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.training.run_record import interrupted_at

    steps = interrupted_at(files)
    if steps is not None:
        raise KeyboardInterrupt(f"{files.run_dir} saved at {steps:,} steps; resume with: {resume_command}")


def _train_seeds(args: argparse.Namespace, config, config_path: Path) -> int:
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.training.multiseed import park_seeds, parse_seeds, seed_jobs, train_seeds

    jobs = seed_jobs(
        config,
        parse_seeds(args.seeds),
        config_path=config_path,
        runs_dir=Path(args.runs_dir),
        ship_to=Path(args.ship_to) if args.ship else None,
        parked_dir=Path(args.parked_dir),
        command=command_line(args),
        make_teacher=_teacher_maker(config),
    )
    if args.park:
        park_seeds(jobs)
        return 0
    policies = train_seeds(jobs, backend=args.backend, address=args.address, parallel=args.parallel)
    print("\n".join(f"seed {job.config.seed}: {policy}" for job, policy in zip(jobs, policies, strict=True)))
    return 0
