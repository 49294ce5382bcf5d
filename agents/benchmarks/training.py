"""``flownav bench train``: PPO training steps per second against the number of env workers.

For each ``n_envs``, the training config's PPO (same network, hyperparameters and env settings) learns for a
few rollouts on fresh workers, after one warm-up rollout that is not timed. A callback splits the wall time
into collecting the rollout (the env workers stepping, the policy acting) and updating the policy, so the
report says which side a change of ``n_envs`` or of the env moves. The held-out evaluation a real run does
every ``eval_every`` steps is left out; its cost is one more single-env episode batch per evaluation.

Every ``n_envs`` is measured in the same process, alternated over the repeats, and quoted as the median of
the repeats with their spread, so that a machine shared with other jobs shifts all of them alike.
"""

from __future__ import annotations

import dataclasses
import statistics
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from agents.common.machine import available_cores
from agents.common.tables import markdown_table, today, write_csv
from agents.training.config import TrainConfig
from agents.training.envs import build_envs, close_quietly
from agents.training.ppo import new_model


def _phase_timer() -> Any:
    """An SB3 callback that adds up the seconds spent collecting rollouts and, between them, updating."""
    from stable_baselines3.common.callbacks import BaseCallback

    class PhaseTimer(BaseCallback):
        def __init__(self) -> None:
            super().__init__()
            self.collect_s = 0.0
            self.update_s = 0.0
            self._mark = time.perf_counter()

        def _on_rollout_start(self) -> None:
            now = time.perf_counter()
            self.update_s += now - self._mark
            self._mark = now

        def _on_rollout_end(self) -> None:
            now = time.perf_counter()
            self.collect_s += now - self._mark
            self._mark = now

        def _on_step(self) -> bool:
            return True

    return PhaseTimer()


def measure_training(
    config: TrainConfig, n_envs: int, rollouts: int, torch_threads: int = 1
) -> dict[str, float]:
    """Steps per second of ``rollouts`` PPO rollouts (and their updates) with ``n_envs`` env workers.

    Returns:
        ``steps``, ``seconds``, ``steps_per_s``, ``collect_s`` and ``update_s`` of the timed rollouts.
    """
    import torch

    torch.set_num_threads(torch_threads)
    config = dataclasses.replace(config, n_envs=n_envs)
    envs, eval_env = build_envs(config)
    close_quietly(eval_env)
    try:
        model = new_model(config, envs)
        per_rollout = config.ppo.n_steps * n_envs
        model.learn(per_rollout)  # warm-up: worker start, first renders, torch's first passes
        timer = _phase_timer()
        started = time.perf_counter()
        model.learn(per_rollout * rollouts, callback=timer, reset_num_timesteps=False)
        seconds = time.perf_counter() - started
    finally:
        close_quietly(envs)
    timer.update_s += max(
        0.0, seconds - timer.collect_s - timer.update_s
    )  # the last update has no next rollout
    steps = per_rollout * rollouts
    return {
        "steps": steps,
        "seconds": seconds,
        "steps_per_s": steps / seconds,
        "collect_s": timer.collect_s,
        "update_s": timer.update_s,
    }


def run_training_benchmark(
    config: TrainConfig,
    config_path: Path,
    n_envs_options: Sequence[int],
    rollouts: int,
    repeats: int,
    out_dir: Path,
    progress: bool = True,
) -> list[Path]:
    """Measure every ``n_envs`` ``repeats`` times, alternating, and write ``training_performance.md`` and
    ``.csv`` to ``out_dir``; returns their paths.

    Raises:
        ValueError: a count below 1.
    """
    if rollouts < 1 or repeats < 1 or not n_envs_options or min(n_envs_options) < 1:
        raise ValueError(
            f"--rollouts, --repeats and every --n-envs must be >= 1, got {rollouts}, {repeats}, "
            f"{list(n_envs_options)}"
        )
    from tqdm import tqdm

    started = time.perf_counter()
    runs: dict[int, list[dict[str, float]]] = {n: [] for n in n_envs_options}
    jobs = [(repeat, n) for repeat in range(repeats) for n in n_envs_options]
    for _, n_envs in tqdm(jobs, desc="bench train", unit="run", disable=not progress):
        runs[n_envs].append(measure_training(config, n_envs, rollouts))
    rows = [_summary(config, n, measured) for n, measured in runs.items()]
    out_dir.mkdir(parents=True, exist_ok=True)
    csv_path, md_path = out_dir / "training_performance.csv", out_dir / "training_performance.md"
    write_csv(csv_path, rows)
    command = (
        f"flownav bench train --config {config_path} --n-envs {','.join(map(str, n_envs_options))} "
        f"--rollouts {rollouts} --repeats {repeats} --out {out_dir}"
    )
    md_path.write_text(_report(rows, config, command, time.perf_counter() - started))
    return [md_path, csv_path]


def _summary(config: TrainConfig, n_envs: int, measured: list[dict[str, float]]) -> dict[str, Any]:
    rates = [m["steps_per_s"] for m in measured]
    steps = sum(m["steps"] for m in measured)
    return {
        "n_envs": n_envs,
        "rollout_steps": config.ppo.n_steps * n_envs,
        "steps_per_s_median": round(statistics.median(rates), 1),
        "steps_per_s_min": round(min(rates), 1),
        "steps_per_s_max": round(max(rates), 1),
        "collect_ms_per_step": round(1000 * sum(m["collect_s"] for m in measured) / steps, 3),
        "update_ms_per_step": round(1000 * sum(m["update_s"] for m in measured) / steps, 3),
        "repeats": len(measured),
    }


def _report(rows: list[dict[str, Any]], config: TrainConfig, command: str, elapsed: float) -> str:
    from agents.benchmarks.common import hardware_summary

    table = markdown_table(
        ["n_envs", "steps per rollout", "steps/s (median)", "min–max", "collect ms/step", "update ms/step"],
        [
            [
                r["n_envs"],
                r["rollout_steps"],
                r["steps_per_s_median"],
                f"{r['steps_per_s_min']}–{r['steps_per_s_max']}",
                r["collect_ms_per_step"],
                r["update_ms_per_step"],
            ]
            for r in rows
        ],
    )
    best = max(rows, key=lambda r: r["steps_per_s_median"])
    return "\n".join(
        [
            "# Training throughput: PPO steps per second against env workers",
            "",
            f"Command: `{command}` ({today()}, {elapsed / 60:.1f} min).  ",
            f"Config `{config.name}`: env `{config.env_id}` {config.env or '(defaults)'}, PPO n_steps "
            f"{config.ppo.n_steps} per env, batch {config.ppo.batch_size}, {config.ppo.n_epochs} epochs, "
            f"network {config.ppo.net_arch}; torch on 1 thread per process; {available_cores()} cores.",
            "",
            hardware_summary(),
            "",
            table,
            "",
            "Steps/s is the median over the repeats (each repeat a fresh set of workers, the settings "
            "alternated), with its min–max. Collect is the wall time of filling the rollout buffer (the "
            "workers step the env in parallel while the main process waits and runs the policy); update is "
            "the PPO epochs over the buffer, during which the workers idle. The held-out evaluation of a real "
            "run is not included.",
            "",
            f"Fastest here: n_envs = {best['n_envs']} at {best['steps_per_s_median']} steps/s. More workers "
            "than cores only help while the main process has work of its own between steps; past that they "
            "share the same cores. A different n_envs also changes the rollout size (n_steps × n_envs), and "
            "with it what one update sees: compare learning curves per step before adopting one.",
            "",
        ]
    )
