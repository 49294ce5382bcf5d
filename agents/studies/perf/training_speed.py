"""``flownav bench train``: PPO training steps per second against the number of env workers, and of
several training runs side by side.

For each ``n_envs``, the training config's PPO (same network, hyperparameters and env settings) learns for a
few rollouts on fresh workers, after one warm-up rollout that is not timed. A callback splits the wall time
into collecting the rollout (the env workers stepping, the policy acting) and updating the policy, so the
report says which side a change of ``n_envs`` or of the env moves. The held-out evaluation a real run does
every ``eval_every`` steps is left out; its cost is one more single-env episode batch per evaluation.

``side_by_side`` runs of the config's own ``n_envs`` are measured too: as many processes at once, each
stepping its envs itself (``flownav train --seeds ... --parallel``), timed from a common start after their
warm-ups; their rate is the machine's, the sum over the runs.

Every setting is measured in the same process, alternated over the repeats, and quoted as the median of
the repeats with their spread, so that a machine shared with other jobs shifts all of them alike.
"""

from __future__ import annotations

import dataclasses
import multiprocessing
import statistics
import time
from collections.abc import Sequence
from multiprocessing.queues import Queue
from multiprocessing.synchronize import Barrier
from pathlib import Path
from typing import Any

from tqdm import tqdm

from agents.common.tables import write_csv
from agents.studies.perf.report_kit import RunFacts, table, write_report
from agents.training.envs import build_envs, close_quietly
from agents.training.ppo import new_model
from agents.training.train_config import TrainConfig

TORCH_THREADS = 1  # per process: the env workers, not torch, are what n_envs spreads over the cores


def _phase_timer() -> Any:
    """An SB3 callback that adds up the seconds spent collecting rollouts and, between them, updating."""
    # stable-baselines3 is imported here: it pulls in torch, slow to import, and only the measurement needs it.
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
    config: TrainConfig,
    n_envs: int,
    rollouts: int,
    *,
    in_process: bool = False,
    start_together: Barrier | None = None,
) -> dict[str, float]:
    """Steps per second of ``rollouts`` PPO rollouts (and their updates) with ``n_envs`` envs, in worker
    processes or, ``in_process``, in this one; ``start_together`` is a barrier that runs side by side wait at
    after their warm-ups.

    Returns:
        ``steps``, ``seconds``, ``steps_per_s``, ``collect_s`` and ``update_s`` of the timed rollouts.
    """
    # torch is imported here: it is slow to import and only the measurement needs it.
    import torch

    torch.set_num_threads(TORCH_THREADS)
    config = dataclasses.replace(config, n_envs=n_envs)
    envs, eval_env = build_envs(config, in_process=in_process)
    close_quietly(eval_env)
    try:
        model = new_model(config, envs)
        per_rollout = config.ppo.n_steps * n_envs
        model.learn(per_rollout)  # warm-up: worker start, first renders, torch's first passes
        if start_together is not None:
            start_together.wait()
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


def _side_by_side_run(
    config: TrainConfig, rollouts: int, barrier: Barrier, results: Queue[dict[str, float]]
) -> None:
    results.put(measure_training(config, config.n_envs, rollouts, in_process=True, start_together=barrier))


def measure_side_by_side(config: TrainConfig, runs: int, rollouts: int) -> dict[str, float]:
    """``runs`` trainings of ``config`` at once, each in a forkserver process stepping its own envs.

    Returns:
        As :func:`measure_training`, summed over the runs (``steps_per_s`` is the machine's rate), with
        ``per_run_steps_per_s`` the slowest run's own rate.
    """
    context = multiprocessing.get_context("forkserver")  # EGL cannot render in a forked child
    barrier, results = context.Barrier(runs), context.Queue()
    processes = [
        context.Process(target=_side_by_side_run, args=(config, rollouts, barrier, results))
        for _ in range(runs)
    ]
    for process in processes:
        process.start()
    measured = [results.get() for _ in processes]
    for process in processes:
        process.join()
    total = {key: sum(m[key] for m in measured) for key in ("steps", "collect_s", "update_s")}
    return {
        **total,
        "seconds": max(m["seconds"] for m in measured),
        "steps_per_s": sum(m["steps_per_s"] for m in measured),
        "per_run_steps_per_s": min(m["steps_per_s"] for m in measured),
    }


def run_training_benchmark(
    config: TrainConfig,
    config_path: Path,
    n_envs_options: Sequence[int],
    rollouts: int,
    repeats: int,
    out_dir: Path,
    progress: bool = True,
    side_by_side: int = 0,
) -> list[Path]:
    """Measure every ``n_envs`` (and, with ``side_by_side`` >= 2, that many runs of the config's own
    ``n_envs`` at once) ``repeats`` times, alternating, and write ``training_throughput.md`` and ``.csv`` to
    ``out_dir``; returns their paths.

    Raises:
        ValueError: a count below 1, or ``side_by_side`` 1 or negative.
    """
    _check_counts(n_envs_options, rollouts, repeats, side_by_side)
    started = time.perf_counter()
    settings = [(n, 1) for n in n_envs_options] + ([(config.n_envs, side_by_side)] if side_by_side else [])
    runs: dict[tuple[int, int], list[dict[str, float]]] = {setting: [] for setting in settings}
    jobs = [(repeat, setting) for repeat in range(repeats) for setting in settings]
    for _, (n_envs, count) in tqdm(jobs, desc="bench train", unit="run", disable=not progress):
        measured = (
            measure_training(config, n_envs, rollouts)
            if count == 1
            else measure_side_by_side(dataclasses.replace(config, n_envs=n_envs), count, rollouts)
        )
        runs[(n_envs, count)].append(measured)
    rows = [_summary(config, n, count, measured) for (n, count), measured in runs.items()]
    out_dir.mkdir(parents=True, exist_ok=True)
    csv_path, md_path = out_dir / "training_throughput.csv", out_dir / "training_throughput.md"
    write_csv(csv_path, rows)
    command = (
        f"flownav bench train --config {config_path} --n-envs {','.join(map(str, n_envs_options))} "
        f"--rollouts {rollouts} --repeats {repeats}"
        + (f" --side-by-side {side_by_side}" if side_by_side else "")
        + f" --out {out_dir}"
    )
    values = throughput_report_values(rows, config, RunFacts.of_this_run(command, started))
    return [write_report(md_path, "training_throughput.md.j2", values), csv_path]


def _check_counts(n_envs_options: Sequence[int], rollouts: int, repeats: int, side_by_side: int) -> None:
    """Refuse counts the benchmark cannot measure, before any env is built."""
    if rollouts < 1 or repeats < 1 or not n_envs_options or min(n_envs_options) < 1:
        raise ValueError(
            f"--rollouts, --repeats and every --n-envs must be >= 1, got {rollouts}, {repeats}, "
            f"{list(n_envs_options)}"
        )
    if side_by_side == 1 or side_by_side < 0:
        raise ValueError(f"--side-by-side must be 0 (off) or >= 2 runs, got {side_by_side}")


def _summary(config: TrainConfig, n_envs: int, runs: int, measured: list[dict[str, float]]) -> dict[str, Any]:
    rates = [m["steps_per_s"] for m in measured]
    steps = sum(m["steps"] for m in measured)
    return {
        "n_envs": n_envs,
        "runs_side_by_side": runs,
        "env_workers": "one subprocess per env" if runs == 1 and n_envs > 1 else "in process",
        "rollout_steps": config.ppo.n_steps * n_envs,
        "steps_per_s_median": round(statistics.median(rates), 1),
        "steps_per_s_min": round(min(rates), 1),
        "steps_per_s_max": round(max(rates), 1),
        "per_run_steps_per_s_median": round(
            statistics.median(m.get("per_run_steps_per_s", m["steps_per_s"]) for m in measured), 1
        ),
        "collect_ms_per_step": round(1000 * sum(m["collect_s"] for m in measured) / steps, 3),
        "update_ms_per_step": round(1000 * sum(m["update_s"] for m in measured) / steps, 3),
        "repeats": len(measured),
    }


def throughput_report_values(
    rows: list[dict[str, Any]], config: TrainConfig, run: RunFacts
) -> dict[str, Any]:
    """Every figure and table of ``templates/training_throughput.md.j2``, from the settings' rows (the single
    runs first, as the CSV has them), the config and the run's facts."""
    columns = {
        "n_envs": "{n_envs}",
        "runs at once": "{runs_side_by_side}",
        "env workers": "{env_workers}",
        "steps per rollout": "{rollout_steps}",
        "steps/s, machine (median)": "{steps_per_s_median}",
        "min–max": "{steps_per_s_min}–{steps_per_s_max}",
        "steps/s per run": "{per_run_steps_per_s_median}",
        "collect ms/step": "{collect_ms_per_step}",
        "update ms/step": "{update_ms_per_step}",
    }
    best = max(rows, key=lambda r: r["steps_per_s_median"])
    single = [r for r in rows if r["runs_side_by_side"] == 1]
    reference = next((r for r in single if r["n_envs"] == config.n_envs), single[0]) if single else None
    side_by_side = [
        {
            "runs": row["runs_side_by_side"],
            "ratio": f"{row['steps_per_s_median'] / reference['steps_per_s_median']:.2f}",
            "n_envs": reference["n_envs"],
        }
        for row in rows[len(single) :]
        if reference is not None
    ]
    return {
        "run": run,
        "config": config.name,
        "env_id": config.env_id,
        "env": config.env or "(defaults)",
        "n_steps": config.ppo.n_steps,
        "batch_size": config.ppo.batch_size,
        "n_epochs": config.ppo.n_epochs,
        "net_arch": config.ppo.net_arch,
        "torch_threads": TORCH_THREADS,
        "table": table(rows, columns),
        "best_n_envs": best["n_envs"],
        "best_runs": best["runs_side_by_side"],
        "best_steps_per_s": best["steps_per_s_median"],
        "side_by_side": side_by_side,
    }
