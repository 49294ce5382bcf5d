"""Agents, training, evaluation, sweeps and their configs, on the real env at small resolutions."""

from __future__ import annotations

import json
import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

import flownav_env  # noqa: F401
from agents.cli import COMMANDS
from agents.config import ConfigError, check_env_kwargs, load_config
from agents.episodes import EpisodeTask, execute, pending_tasks, run_task
from agents.evaluation import (
    EVAL_SEED_START,
    drop_agents,
    read_records,
    run_episode,
    summarise,
    wilson_interval,
)
from agents.policies import BeeAgent, StraightAgent, agent_env_kwargs, load_agent, sector_nearness
from agents.sweep import SweepConfig, build_tasks
from agents.train import TrainConfig, latest_checkpoint, train
from agents.wrappers import SensorRandomization

SMALL = {"camera_width": 96, "camera_height": 72}


def test_bee_passes_the_single_capsule_where_straight_collides() -> None:
    env = gym.make("FlowNavSingle-v0")
    straight = run_episode(env, StraightAgent(), seed=0, label="straight")
    bee = run_episode(env, BeeAgent(), seed=0, label="bee")
    env.close()
    assert straight.collision and not straight.success
    assert bee.success and not bee.collision
    assert bee.min_clearance_m > 0.2


def test_agents_accept_batched_observations_like_sb3() -> None:
    env = gym.make("FlowNav-v0", **SMALL)
    observation, _ = env.reset(seed=0)
    observation, *_ = env.step(np.zeros(3))
    env.close()
    batch = {key: np.stack([value, value]) for key, value in observation.items()}
    for agent in (BeeAgent(), StraightAgent()):
        single, _ = agent.predict(observation)
        batched, _ = agent.predict(batch)
        assert single.shape == (3,) and batched.shape == (2, 3)
        np.testing.assert_allclose(batched[0], single)
        assert np.all(np.abs(single) <= 1)


def test_bee_turns_away_from_the_nearer_side() -> None:
    histogram = np.zeros((3, 5, 6), np.float32)
    histogram[:2, 0, 0] = 1.0  # something within 1 m on the left
    histogram[:2, 4, 5] = 1.0  # the right side is far
    state = np.array([1.0, 0, 0, 0, 0, 1.0, 0.0], np.float32)
    action, _ = BeeAgent().predict({"depth_histogram": histogram, "state": state})
    assert action[0] > 0.5  # slides right
    assert sector_nearness(histogram, BeeAgent().bin_edges)[0, 0] == pytest.approx(2.0)


def test_wilson_interval_matches_known_values() -> None:
    low, high = wilson_interval(5, 10)
    assert low == pytest.approx(0.2366, abs=1e-3) and high == pytest.approx(0.7634, abs=1e-3)
    assert wilson_interval(0, 10)[0] == 0.0
    assert wilson_interval(0, 0) == (0.0, 1.0)


def tiny_train_config(tmp_path: Path, total: int) -> tuple[TrainConfig, Path]:
    config_path = tmp_path / "tiny.yaml"
    config_path.write_text(
        yaml.safe_dump(
            {
                "name": "ppo_flow",
                "env_id": "FlowNavSingle-v0",
                "env": SMALL,
                "total_timesteps": total,
                "n_envs": 1,
                "checkpoint_every": 128,
                "eval_every": 128,
                "eval_episodes": 1,
                "ppo": {"n_steps": 64, "batch_size": 32, "n_epochs": 1, "net_arch": [16]},
            }
        )
    )
    return load_config(config_path, TrainConfig), config_path


def test_tiny_ppo_run_saves_loads_and_resumes(tmp_path: Path) -> None:
    from stable_baselines3 import PPO

    config, path = tiny_train_config(tmp_path, total=128)
    policy = train(
        config, config_path=path, resume=False, runs_dir=tmp_path / "runs", policies_dir=tmp_path / "pol"
    )
    checkpoints = tmp_path / "runs" / "ppo_flow" / "checkpoints"
    assert PPO.load(latest_checkpoint(checkpoints), device="cpu").num_timesteps == 128
    assert (tmp_path / "pol" / "ppo_flow.yaml").exists() and (tmp_path / "pol" / "ppo_flow.json").exists()

    config.total_timesteps = 256  # as if the first run had been interrupted at 128 of 256 steps
    policy = train(
        config, config_path=path, resume=True, runs_dir=tmp_path / "runs", policies_dir=tmp_path / "pol"
    )
    assert PPO.load(latest_checkpoint(checkpoints), device="cpu").num_timesteps == 256
    record = json.loads((tmp_path / "pol" / "ppo_flow.json").read_text())
    assert record["total_timesteps"] == 256 and len(record["sessions"]) == 2
    assert record["sessions"][-1]["env_estimator_defaults"] == {"fast_threshold": 10}
    assert record["sessions"][-1]["code"].startswith("commit") and record["sessions"][-1]["gl_renderer"]
    assert record["selected"].startswith("best held-out eval")  # the shipped policy is the best evaluated one

    agent = load_agent("ppo_flow", policy)
    env = gym.make("FlowNavSingle-v0", **SMALL)
    observation, _ = env.reset(seed=EVAL_SEED_START)
    action, _ = agent.predict(observation, deterministic=True)
    env.close()
    assert action.shape == (3,)


def test_learned_agents_fly_with_the_env_settings_they_were_trained_with(tmp_path: Path) -> None:
    policy = tmp_path / "ppo_oracle.zip"
    policy.with_suffix(".yaml").write_text(
        yaml.safe_dump({"name": "ppo_oracle", "env": {"obs_source": "oracle", **SMALL}})
    )
    assert agent_env_kwargs("ppo_oracle", policy) == {"obs_source": "oracle", **SMALL}
    task = EpisodeTask(
        "ppo_oracle", "brightness", 0.5, 0, policy=str(policy), env_kwargs=(("brightness", 0.5),)
    )
    assert task.env_settings() == {"obs_source": "oracle", **SMALL, "brightness": 0.5}
    override = EpisodeTask(
        "ppo_oracle", "clean", 0.0, 0, policy=str(policy), env_kwargs=(("camera_width", 64),)
    )
    assert override.env_settings()["camera_width"] == 64  # the task's settings win
    assert agent_env_kwargs("bee") == {} and agent_env_kwargs("ppo_robust", tmp_path / "none.zip") == {}
    nested = (*SMALL.items(), ("estimator_kwargs", {"min_parallax_px": 2.0}))  # a dict inside the settings
    assert run_task(EpisodeTask("straight", "clean", 0.0, 0, "FlowNavSingle-v0", nested)).collision


def test_evaluation_resumes_after_interruption(tmp_path: Path) -> None:
    csv_path = tmp_path / "episodes.csv"
    env_kwargs = tuple(sorted(SMALL.items()))
    tasks = [
        EpisodeTask("straight", "clean", 0.0, EVAL_SEED_START + i, "FlowNavSingle-v0", env_kwargs)
        for i in range(2)
    ]
    assert execute(tasks[:1], csv_path) == 1  # "interrupted" after the first episode
    with csv_path.open("a") as handle:
        handle.write("straight,clean,0.0,1000001,Tr")  # an episode torn mid-write is not counted
    assert [t.seed for t in pending_tasks(tasks, csv_path)] == [EVAL_SEED_START + 1]
    assert execute(tasks, csv_path) == 1
    rows = read_records(csv_path)
    assert sorted(r["seed"] for r in rows) == [EVAL_SEED_START, EVAL_SEED_START + 1]
    assert all(r["collision"] for r in rows)


def write_sweep_config(tmp_path: Path, **overrides) -> Path:
    config = {
        "agents": ["straight", "bee"],
        "env_id": "FlowNavSingle-v0",
        "env": SMALL,
        "episodes": 2,
        "workers": 1,
        "factors": {"rotation_error": [0.1]},
        **overrides,
    }
    path = tmp_path / "sweep.yaml"
    path.write_text(yaml.safe_dump(config))
    return path


def test_sweep_writes_summary_and_figure_on_the_real_env(tmp_path: Path) -> None:
    from agents.cli import main

    config_path = write_sweep_config(tmp_path)
    assert main(["sweep", "--config", str(config_path), "--out", str(tmp_path / "out")]) == 0
    summary = (tmp_path / "out" / "sweep.csv").read_text().splitlines()
    assert summary[0].startswith(
        "agent,factor,level,episodes,collisions,collision_rate,ci_low,ci_high,success_rate"
    )
    assert len(summary) == 1 + 2 * 2  # 2 agents × (clean + 1 level)
    assert (tmp_path / "out" / "collision_vs_error.png").stat().st_size > 10_000
    rows = read_records(tmp_path / "out" / "sweep_episodes.csv")
    table = {(r["agent"], r["factor"]): r for r in summarise(rows)}
    assert table[("straight", "clean")]["collision_rate"] == 1.0

    # --report-only rebuilds the outputs from the episodes so far and flies nothing, even when more are asked for
    (tmp_path / "out" / "sweep.csv").unlink()
    args = ["sweep", "--config", str(config_path), "--out", str(tmp_path / "out"), "--episodes", "5"]
    assert main([*args, "--report-only"]) == 0
    assert len(read_records(tmp_path / "out" / "sweep_episodes.csv")) == len(rows)
    assert len((tmp_path / "out" / "sweep.csv").read_text().splitlines()) == 1 + 2 * 2
    assert "Rebuilt with `--report-only`" in (tmp_path / "out" / "sweep.md").read_text()
    assert "fast_threshold" in (tmp_path / "out" / "sweep.md").read_text()

    # --refly flies one agent again (a retrained policy); --compare-with sets each cell beside an earlier sweep
    earlier = tmp_path / "earlier.csv"
    earlier.write_bytes((tmp_path / "out" / "sweep_episodes.csv").read_bytes())
    assert main([*args[:-2], "--refly", "bee", "--compare-with", str(earlier)]) == 0
    refilled = read_records(tmp_path / "out" / "sweep_episodes.csv")
    assert sorted(map(str, refilled)) == sorted(map(str, rows))  # the bee is deterministic on the same seeds
    assert [r["agent"] for r in refilled][-4:] == ["bee"] * 4
    report = (tmp_path / "out" / "sweep.md").read_text()
    assert f"## Against `{earlier}`" in report
    assert "| clean | – | 2 | 0.00 | 1.00 | 0.00 / 1.00 | 2/2 / 2/2 |" in report


def test_a_sweep_of_no_factors_flies_the_clean_cell_and_plots_it(tmp_path: Path) -> None:
    from agents.cli import main

    config_path = write_sweep_config(tmp_path, agents=["straight"], episodes=1, factors={})
    assert main(["sweep", "--config", str(config_path), "--out", str(tmp_path / "out")]) == 0
    assert len((tmp_path / "out" / "sweep.csv").read_text().splitlines()) == 2
    assert (tmp_path / "out" / "collision_vs_error.png").stat().st_size > 5_000


def test_drop_agents_deletes_only_their_rows_and_keeps_the_rest_byte_for_byte(tmp_path: Path) -> None:
    path = tmp_path / "episodes.csv"
    assert drop_agents(path, ["bee"]) == 0  # no file yet: nothing to delete
    tasks = [
        EpisodeTask(agent, "clean", 0.0, EVAL_SEED_START, "FlowNavSingle-v0", tuple(SMALL.items()), None)
        for agent in ("straight", "bee")
    ]
    execute(tasks, path)
    header, straight_line, _ = path.read_text().splitlines(keepends=True)
    assert drop_agents(path, ["bee", "ppo_flow"]) == 1
    assert path.read_text() == header + straight_line
    assert not path.with_name(path.name + ".tmp").exists()


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--refly", "ppo_flow"], r"--refly: 'ppo_flow' is not an agent of .*sweep.yaml \(straight, bee\)"),
        (["--refly", "bee", "--report-only"], "cannot be combined with --report-only"),
        (["--compare-with", "nowhere.csv"], "--compare-with: no episodes CSV at nowhere.csv"),
    ],
)
def test_sweep_rejects_bad_refly_and_compare_options(
    tmp_path: Path, capsys, extra: list, message: str
) -> None:
    import re

    from agents.cli import main

    args = ["sweep", "--config", str(write_sweep_config(tmp_path)), "--out", str(tmp_path / "out"), *extra]
    assert main(args) == 2
    assert re.search(message, capsys.readouterr().err)
    assert not (tmp_path / "out" / "sweep_episodes.csv").exists()


def test_sweep_flies_in_seed_passes_so_a_cut_short_sweep_covers_every_cell_and_agent(tmp_path: Path) -> None:
    config = load_config(write_sweep_config(tmp_path), SweepConfig)
    config.episodes, config.seed_block = 3, 2
    order = [
        (t.factor, t.agent, t.seed - config.seed_start) for t in build_tasks(config, ["straight", "bee"])
    ]
    assert order == [
        ("clean", "straight", 0), ("clean", "straight", 1), ("clean", "bee", 0), ("clean", "bee", 1),
        ("rotation_error", "straight", 0), ("rotation_error", "straight", 1),
        ("rotation_error", "bee", 0), ("rotation_error", "bee", 1),
        ("clean", "straight", 2), ("clean", "bee", 2),
        ("rotation_error", "straight", 2), ("rotation_error", "bee", 2),
    ]  # fmt: skip
    config.seed_block = 3  # one pass: the cells one after the other
    assert [(t.factor, t.agent) for t in build_tasks(config, ["bee"])] == [("clean", "bee")] * 3 + [
        ("rotation_error", "bee")
    ] * 3


def test_sweep_runs_on_a_local_ray_instance(tmp_path: Path) -> None:
    pytest.importorskip("ray")
    config = load_config(write_sweep_config(tmp_path, agents=["straight"], episodes=1), SweepConfig)
    tasks = build_tasks(config, ["straight"])
    local_csv, ray_csv = tmp_path / "local.csv", tmp_path / "ray.csv"
    execute(tasks, local_csv)
    execute(tasks, ray_csv, backend="ray", workers=1)
    key = ["seed", "factor", "level", "collision", "progress_m"]
    assert [[r[k] for k in key] for r in read_records(local_csv)] == [
        [r[k] for k in key] for r in sorted(read_records(ray_csv), key=lambda r: r["factor"])
    ]


def test_evaluate_command_prints_the_table(tmp_path: Path, capsys) -> None:
    from agents.cli import main

    args = [
        "evaluate",
        "--agent",
        "bee",
        "--episodes",
        "1",
        "--env-id",
        "FlowNavSingle-v0",
        "--env",
        "camera_width=96",
        "--env",
        "camera_height=72",
        "--out",
        str(tmp_path / "e.csv"),
    ]
    assert main(args) == 0
    assert "| bee |" in capsys.readouterr().out


def test_video_writes_an_mp4(tmp_path: Path) -> None:
    import imageio.v2 as imageio

    from agents.video import record_episode

    out = tmp_path / "bee.mp4"
    record_episode("bee", "FlowNavSingle-v0", EVAL_SEED_START, out, max_steps=5)
    frames = [frame for frame in imageio.get_reader(out)]  # list() trips on the reader's infinite len()
    assert len(frames) == 5 and frames[0].shape == (240, 640, 3)


def test_sensor_randomization_draws_within_ranges_reproducibly() -> None:
    def draws(seed: int) -> dict:
        env = SensorRandomization(
            gym.make("FlowNav-v0", **SMALL), {"rotation_error": [0.0, 0.1], "brightness": [0.5, 1.5]}
        )
        _, info = env.reset(seed=seed)
        env.close()
        return info

    first, again, other = draws(3), draws(3), draws(4)
    assert 0.0 <= first["sensor_rotation_error"] <= 0.1 and 0.5 <= first["sensor_brightness"] <= 1.5
    assert first["sensor_rotation_error"] == again["sensor_rotation_error"]
    assert first["sensor_rotation_error"] != other["sensor_rotation_error"]
    with pytest.raises(ValueError, match=r"ranges may only name .*got \['speed'\]"):
        SensorRandomization(gym.make("FlowNav-v0", **SMALL), {"speed": [0, 1]})


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ({"name": "x", "total_steps": 5}, r"unknown key 'total_steps'"),
        ({"name": "x", "n_envs": "two"}, r"key 'n_envs' must be an integer, got 'two'"),
        ({"name": "x", "n_envs": 0}, r"key 'n_envs' must be in \[1, 64\], got 0"),
        ({"name": "x", "ppo": {"gamma": 1.5}}, r"key 'ppo.gamma' must be in \[0.0, 1.0\], got 1.5"),
        ({"name": "x", "ppo": {"lr": 0.1}}, r"unknown key 'ppo.lr'"),
        (
            {"name": "x", "randomize": {"brightness": [2.0, 1.0]}},
            r"randomize.brightness' must be \[low, high\]",
        ),
        ({"name": "x", "env": {"forward_speed": -1}}, r"key 'env.forward_speed': forward_speed must be in"),
        ({"name": "x", "env": {"wind": 3}}, r"unknown key 'env.wind' \(not a FlowNavEnv argument\)"),
        ({"n_envs": 2}, r"missing required key 'name'"),
    ],
)
def test_train_config_errors_name_the_file_and_the_key(tmp_path: Path, content: dict, message: str) -> None:
    from agents.config import check_env_kwargs

    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(content))
    with pytest.raises(ConfigError, match=message) as error:
        config = load_config(path, TrainConfig)
        check_env_kwargs(config.env, str(path))
    assert str(path) in str(error.value)


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"agents": ["wasp"]}, r"key 'agents': unknown agent 'wasp'"),
        ({"factors": {"wind": [1.0]}}, r"key 'factors.wind': not a sweep factor"),
        ({"episodes": 0}, r"key 'episodes' must be in \[1, 100000\], got 0"),
        ({"backend": "slurm"}, r"key 'backend' must be one of 'local', 'ray', got 'slurm'"),
        ({"seed_start": 5}, r"key 'seed_start' must be in \[1000000, inf\], got 5"),
    ],
)
def test_sweep_config_errors_name_the_file_and_the_key(tmp_path: Path, overrides: dict, message: str) -> None:
    path = write_sweep_config(tmp_path, **overrides)
    with pytest.raises(ConfigError, match=message) as error:
        load_config(path, SweepConfig)
    assert str(path) in str(error.value)


def test_config_file_errors(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="config file not found"):
        load_config(tmp_path / "missing.yaml", TrainConfig)
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: [unclosed")
    with pytest.raises(ConfigError, match="not valid YAML"):
        load_config(bad, TrainConfig)


def test_shipped_configs_load() -> None:
    root = Path(__file__).resolve().parents[1] / "configs"
    for name in ("ppo_flow", "ppo_robust", "ppo_oracle"):
        assert load_config(root / f"{name}.yaml", TrainConfig).name == name
    for experiment in sorted((root / "experiments").glob("*.yaml")):
        config = load_config(experiment, TrainConfig)
        assert config.name == experiment.stem and check_env_kwargs(config.env, str(experiment)) == config.env
    assert math.isclose(len(load_config(root / "sweep.yaml", SweepConfig).factors), 5)
    for sweep in sorted(root.glob("sweep_*.yaml")):
        config = load_config(sweep, SweepConfig)
        assert check_env_kwargs(config.env, str(sweep)) == config.env


def test_unknown_agent_and_missing_policy_errors(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"agent must be one of .*got 'wasp'"):
        load_agent("wasp")
    with pytest.raises(FileNotFoundError, match=r"policy file for agent 'ppo_flow' not found"):
        load_agent("ppo_flow", tmp_path / "none.zip")


def test_cli_reports_bad_input_in_one_line(capsys) -> None:
    from agents.cli import main

    assert main(["evaluate", "--agent", "bee", "--episodes", "0"]) == 2
    assert "flownav evaluate: error: --episodes must be >= 1, got 0" in capsys.readouterr().err


@pytest.mark.parametrize("command", [[], *[[name] for name in COMMANDS]])
def test_every_help_page_renders(command: list[str], capsys) -> None:
    # argparse %-formats help strings: a bare "%" in one crashes `flownav --help` itself.
    from agents.cli import main

    with pytest.raises(SystemExit) as exit_info:
        main([*command, "--help"])
    assert exit_info.value.code == 0
    assert "usage: flownav" in capsys.readouterr().out


def test_curves_command_plots_every_run_and_rejects_missing_files(tmp_path: Path, capsys) -> None:
    from agents.cli import main
    from agents.curves import run_label

    for name, scale in (("ppo_a", 1.0), ("ppo_b", 2.0)):
        np.savez(
            tmp_path / f"{name}_evaluations.npz",
            timesteps=np.array([100, 200, 300]),
            results=scale * np.arange(6.0).reshape(3, 2),
        )
    out = tmp_path / "curves.png"
    files = [str(tmp_path / "ppo_a_evaluations.npz"), str(tmp_path / "ppo_b_evaluations.npz")]
    assert main(["curves", *files, "--out", str(out)]) == 0
    assert out.stat().st_size > 10_000
    assert run_label(Path("runs/ppo_x/evaluations.npz")) == "ppo_x"
    assert main(["curves", str(tmp_path / "none.npz"), "--out", str(out)]) == 2
    assert "evaluations file not found" in capsys.readouterr().err
