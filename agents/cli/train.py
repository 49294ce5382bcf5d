"""``flownav train``: PPO on FlowNav from a YAML config (see :mod:`agents.training.ppo`).

A run writes only under ``<runs-dir>/<name>/``: policy, config copy, record, evaluations, learning curve,
checkpoints and TensorBoard logs. Shipping it to the policies folder that the benchmark flies
(``results/policies/``) is deliberate: ``--ship`` at the end of training, or ``--ship-only`` for a finished run.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from agents.common.paths import POLICIES_DIR
from agents.training.parking import PARKED_DIR

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
        "steps its own envs (same rollouts; on 2 cores, 2 side by side train about 1.4x the steps per second "
        "of one at a time, see results/training_performance.md). Default 1",
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
    parser.add_argument("--total-timesteps", type=int, help="override the config's total_timesteps")
    parser.add_argument("--max-minutes", type=float, help="override the config's wall-clock budget")


def run(args: argparse.Namespace) -> int:
    from agents.common.config import check_env_kwargs, load_config
    from agents.training.config import TrainConfig, override
    from agents.training.outputs import RunFiles
    from agents.training.ppo import train
    from agents.training.shipping import ship_run

    config_path = Path(args.config)
    config = load_config(config_path, TrainConfig)
    if args.seeds is not None and args.resume:
        raise ValueError("--seeds always resumes unfinished seeds: drop --resume")
    if args.park and (args.seeds is None or args.ship or args.ship_only):
        raise ValueError("--park takes --seeds and no shipping options: it copies unfinished seeds aside")
    if args.ship_only and args.seeds is not None:
        from agents.training.multiseed import parse_seeds

        for seed in parse_seeds(args.seeds):
            ship_run(
                RunFiles.of_seed(Path(args.runs_dir), config.name, seed), Path(args.ship_to) / config.name
            )
        return 0
    if args.ship_only:
        if args.resume or args.ship or args.total_timesteps is not None or args.max_minutes is not None:
            raise ValueError("--ship-only ships a finished run: it takes no training options")
        ship_run(RunFiles.of(Path(args.runs_dir), config.name), Path(args.ship_to))
        return 0
    override(config, "total_timesteps", args.total_timesteps, "--total-timesteps")
    override(config, "max_minutes", args.max_minutes, "--max-minutes")
    check_env_kwargs(config.env, str(config_path))
    if args.seeds is not None:
        return _train_seeds(args, config, config_path)
    if args.backend != "local" or args.address is not None or args.parallel != 1:
        raise ValueError("--backend, --address and --parallel apply to --seeds runs only")
    train(
        config,
        config_path=config_path,
        resume=args.resume,
        runs_dir=Path(args.runs_dir),
        ship_to=Path(args.ship_to) if args.ship else None,
    )
    return 0


def _train_seeds(args: argparse.Namespace, config, config_path: Path) -> int:
    from agents.training.multiseed import park_seeds, parse_seeds, seed_jobs, train_seeds

    jobs = seed_jobs(
        config,
        parse_seeds(args.seeds),
        config_path=config_path,
        runs_dir=Path(args.runs_dir),
        ship_to=Path(args.ship_to) if args.ship else None,
        parked_dir=Path(args.parked_dir),
    )
    if args.park:
        park_seeds(jobs)
        return 0
    policies = train_seeds(jobs, backend=args.backend, address=args.address, parallel=args.parallel)
    print("\n".join(f"seed {job.config.seed}: {policy}" for job, policy in zip(jobs, policies, strict=True)))
    return 0
