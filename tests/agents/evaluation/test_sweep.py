"""The sensor-error sweep: tasks, resumption, reports, backends and config errors."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import yaml

import flownav_env  # noqa: F401
from agents.analysis.records import read_records
from agents.analysis.statistics import summarise
from agents.common.yaml_config import ConfigError, load_config
from agents.evaluation.runner import execute
from agents.evaluation.sweep import SweepConfig, build_tasks, pool_every_seed, pool_seeds, seed_rotation

SMALL = {"camera_width": 96, "camera_height": 72}


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
    report = (tmp_path / "out" / "sweep.md").read_text()
    assert report.startswith("# Sweep: failure rate per agent and sensor error") and "Partial" not in report
    straight_clean = next(line for line in report.splitlines() if line.startswith("| straight | 1.00 ["))
    assert straight_clean.split(" | ")[1].endswith("(1.00)")  # failure [CI] (collision)

    # --report-only rebuilds the outputs from the episodes so far and flies nothing, even when more are asked for
    (tmp_path / "out" / "sweep.csv").unlink()
    args = ["sweep", "--config", str(config_path), "--out", str(tmp_path / "out"), "--layouts", "5"]
    assert main([*args, "--report-only"]) == 0
    assert len(read_records(tmp_path / "out" / "sweep_episodes.csv")) == len(rows)
    assert len((tmp_path / "out" / "sweep.csv").read_text().splitlines()) == 1 + 2 * 2
    assert "Rebuilt with `--report-only`" in (tmp_path / "out" / "sweep.md").read_text()
    assert "fast_threshold" in (tmp_path / "out" / "sweep.md").read_text()
    assert (
        "**Partial: 4 of 4 cells have fewer than the config's 5 episodes** (fewest: "
        in (tmp_path / "out" / "sweep.md").read_text()
    )

    # --refly flies one agent again (a retrained policy); --compare-with sets each cell beside an earlier sweep
    earlier = tmp_path / "earlier.csv"
    earlier.write_bytes((tmp_path / "out" / "sweep_episodes.csv").read_bytes())
    assert main([*args[:-2], "--agents", "bee", "--refly", "--compare-with", str(earlier)]) == 0
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


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (
            ["--agents", "ppo_flow", "--refly"],
            r"--refly: 'ppo_flow' is not an agent of .*sweep.yaml \(straight, bee\)",
        ),
        (["--agents", "bee", "--refly", "--report-only"], "cannot be combined with --report-only"),
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


def test_a_v2_sweep_cut_short_on_ray_resumes_there_without_duplicates(tmp_path: Path) -> None:
    pytest.importorskip("ray")
    config = load_config(
        write_sweep_config(
            tmp_path,
            agents=["straight"],
            env_id="FlowNav-v1",
            episodes=2,
            factors={"velocity_correlation_s": [1.0]},
        ),
        SweepConfig,
    )
    tasks = build_tasks(config, ["straight"])
    episodes_csv = tmp_path / "sweep_episodes.csv"
    assert execute(tasks[:2], episodes_csv, backend="ray", workers=1) == 2  # a run cut short
    assert execute(tasks, episodes_csv, backend="ray", workers=1) == len(tasks) - 2  # resumed: the rest only
    keys = [(r["factor"], r["level"], r["seed"]) for r in read_records(episodes_csv)]
    assert len(keys) == len(set(keys)) == len(tasks) == 4
    assert {r["env_id"] for r in read_records(episodes_csv)} == {"FlowNav-v1"}


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"agents": ["wasp"]}, r"key 'agents': agent must be one of straight, .*, got 'wasp'"),
        ({"factors": {"wind": [1.0]}}, r"key 'factors.wind': not a sweep factor"),
        ({"agents": ["bee@all"]}, r"key 'agents': 'bee@all': '@all' follows a learned agent's name"),
        ({"agents": ["ppo_flow@allx"]}, r"key 'agents': 'ppo_flow@allx': '@all' follows"),
        ({"agents": ["ppo_flow@x"]}, r"key 'agents': a training seed must be an integer >= 0"),
        ({"episodes": 0}, r"key 'episodes' must be in \[1, 100000\], got 0"),
        ({"backend": "slurm"}, r"key 'backend' must be one of 'local', 'ray', got 'slurm'"),
        ({"seed_start": 5}, r"key 'seed_start' must be in \[1000000, inf\], got 5"),
        (
            {"factors": {"brightness": [0.5, 1.0, 9.0]}},
            r"key 'factors.brightness\[2\]': brightness must be in \[0.0, 4.0\], got 9.0",
        ),
        (
            {"factors": {"forward_speed": [-1.0]}},
            r"key 'factors.forward_speed\[0\]': forward_speed must be in",
        ),
        (
            {"factors": {"depth_noise": [0.1], "rotation_bias": [-0.2, 1.5]}},
            r"key 'factors.rotation_bias\[1\]': rotation_bias must be in \[-0.9, 0.9\], got 1.5",
        ),
    ],
)
def test_sweep_config_errors_name_the_file_and_the_key(tmp_path: Path, overrides: dict, message: str) -> None:
    path = write_sweep_config(tmp_path, **overrides)
    with pytest.raises(ConfigError, match=message) as error:
        load_config(path, SweepConfig)
    assert str(path) in str(error.value)


def test_report_only_rebuilds_the_committed_sweep_from_its_pre_identity_csv(tmp_path: Path) -> None:
    from agents.cli import main
    from agents.common.locations import CONFIGS_DIR, RESULTS_DIR

    shutil.copy(RESULTS_DIR / "sweep_thesis_range" / "sweep_episodes.csv", tmp_path / "sweep_episodes.csv")
    config = str(CONFIGS_DIR / "sweep_thesis_range.yaml")  # the config the committed sweep was flown with
    assert main(["sweep", "--config", config, "--out", str(tmp_path), "--report-only"]) == 0
    assert (tmp_path / "sweep.csv").read_text() == (
        RESULTS_DIR / "sweep_thesis_range" / "sweep.csv"
    ).read_text()


def test_a_sweep_into_a_pre_identity_csv_is_refused_until_overwrite(tmp_path: Path, capsys) -> None:
    from agents.analysis.csv_file import LEGACY_FIELDS
    from agents.cli import main

    out = tmp_path / "out"
    out.mkdir()
    rows = [
        f"{agent},{factor},{level},{seed},False,True,False,False,20.0,20.0,200,0.5,20.0,100.0,0.05,10.0"
        for agent in ("straight", "bee")
        for factor, level in (("clean", 0.0), ("rotation_error", 0.1))
        for seed in (1_000_000, 1_000_001)
    ]
    old = ",".join(LEGACY_FIELDS) + "\r\n" + "".join(row + "\r\n" for row in rows)
    (out / "sweep_episodes.csv").write_text(old, newline="")
    args = ["sweep", "--config", str(write_sweep_config(tmp_path, episodes=1)), "--out", str(out)]
    assert main([*args, "--report-only"]) == 0  # reads: 1 of its 2 seeds per cell
    assert [line.split(",")[3] for line in (out / "sweep.csv").read_text().splitlines()[1:]] == ["1"] * 4
    capsys.readouterr()
    assert main(args) == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1 and "sweep_episodes.csv predates episode identities" in error[0]
    assert "--overwrite" in error[0]
    assert main([*args, "--agents", "bee", "--refly"]) == 2  # refused before deleting anything
    assert (out / "sweep_episodes.csv").read_bytes() == old.encode()
    assert main([*args, "--overwrite"]) == 0
    (backup,) = out.glob("sweep_episodes.csv.bak-*")
    assert backup.read_bytes() == old.encode()
    assert len(read_records(out / "sweep_episodes.csv")) == 4  # flown again, with their identity


def test_relative_policy_dirs_resolve_against_the_repository(tmp_path: Path, monkeypatch) -> None:
    from agents.common.locations import POLICIES_DIR

    config = load_config(write_sweep_config(tmp_path, agents=["ppo_flow"]), SweepConfig)
    monkeypatch.chdir(tmp_path)
    assert config.policy_folder() == POLICIES_DIR
    # An agent named alone stands for its first shipped training seed (there is no single ppo_flow.zip).
    assert {Path(t.policy) for t in build_tasks(config, ["ppo_flow"])} == {
        POLICIES_DIR / "ppo_flow" / "seed_0.zip"
    }


def test_all_seeds_of_a_learned_agent_share_each_cells_layouts_in_turn(tmp_path: Path) -> None:
    policies = tmp_path / "policies"
    (policies / "ppo_flow").mkdir(parents=True)
    for seed in (0, 1, 4):
        (policies / "ppo_flow" / f"seed_{seed}.zip").write_bytes(b"")
    config = load_config(
        write_sweep_config(tmp_path, agents=["bee", "ppo_flow@all"], policy_dir=str(policies), episodes=7),
        SweepConfig,
    )
    tasks = [t for t in build_tasks(config, config.agents) if t.factor == "clean"]
    learned = [(t.seed - config.seed_start, t.agent) for t in tasks if t.agent != "bee"]
    assert learned == [(i, f"ppo_flow@{(0, 1, 4)[i % 3]}") for i in range(7)]
    assert {t.policy for t in tasks if t.agent == "ppo_flow@4"} == {str(policies / "ppo_flow" / "seed_4.zip")}
    rows = [{"agent": t.agent, "seed": t.seed} for t in tasks]
    assert {r["agent"] for r in pool_seeds(rows, config.agents)} == {"bee", "ppo_flow@all"}


def test_training_seeds_keeps_a_flown_sweeps_rotation_when_more_seeds_are_shipped(tmp_path: Path) -> None:
    policies = tmp_path / "policies"
    (policies / "ppo_flow").mkdir(parents=True)
    for seed in range(4):
        (policies / "ppo_flow" / f"seed_{seed}.zip").write_bytes(b"")
    config = load_config(
        write_sweep_config(
            tmp_path, agents=["ppo_flow@all"], policy_dir=str(policies), episodes=5, training_seeds=2
        ),
        SweepConfig,
    )
    assert seed_rotation(config, "ppo_flow@all") == ["ppo_flow@0", "ppo_flow@1"]
    clean = [t.agent for t in build_tasks(config, config.agents) if t.factor == "clean"]
    assert clean == ["ppo_flow@0", "ppo_flow@1"] * 2 + ["ppo_flow@0"]


def test_a_negative_training_seed_count_is_refused_naming_the_range(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"training_seeds.*-1"):
        load_config(write_sweep_config(tmp_path, training_seeds=-1), SweepConfig)


def test_episodes_read_without_their_config_pool_every_training_seed() -> None:
    rows = [
        {"agent": name, "seed": 1}
        for name in ("bee", "ppo_flow@0", "ppo_flow@3", "ppo_oracle@1", "ppo_robust")
    ]
    assert [r["agent"] for r in pool_every_seed(rows)] == [
        "bee",
        "ppo_flow@all",
        "ppo_flow@all",
        "ppo_oracle@all",
        "ppo_robust",
    ]


def test_obstacle_density_is_swept_as_a_course_factor(tmp_path: Path) -> None:
    from agents.cli import main

    config_path = write_sweep_config(
        tmp_path, agents=["straight"], env_id="FlowNav-v0", factors={"obstacle_density": [0.3]}
    )
    assert main(["sweep", "--config", str(config_path), "--out", str(tmp_path / "out")]) == 0
    rows = read_records(tmp_path / "out" / "sweep_episodes.csv")
    dense = [r for r in rows if r["factor"] == "obstacle_density"]
    assert len(dense) == 2 and all('"obstacle_density":0.3' in r["env_kwargs"] for r in dense)
    assert all("obstacle_density" not in r["env_kwargs"] for r in rows if r["factor"] == "clean")


def test_the_partial_warning_counts_cells_not_flown_at_all() -> None:
    from agents.pages.sweep_report import partial_lines

    table = [{"episodes": 100}, {"episodes": 100}]
    assert partial_lines(table, 100, expected_cells=2) == []
    warning = partial_lines(table, 100, expected_cells=5)[1]
    assert (
        "**Partial: 3 of 5 cells have fewer than the config's 100 episodes** (fewest: 0; 3 of them" in warning
    )
