"""Reactive and learned agents behind one predict interface; loading trained policies safely."""

from __future__ import annotations

import shutil
import warnings
import zipfile
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

import flownav_env  # noqa: F401
from agents.common.locations import POLICIES_DIR
from agents.common.manifest import MANIFEST_NAME, file_sha256, read_manifest
from agents.common.seeds import TEST_SEED_START
from agents.evaluation.episode import run_episode
from agents.policies import (
    BeeAgent,
    LoadedPolicy,
    StraightAgent,
    UnverifiedPolicyWarning,
    agent_env_kwargs,
    agent_parameters,
    is_per_tier,
    load_agent,
    load_policy,
    policy_file,
    policy_folder,
    sector_nearness,
)
from flownav_env.tiers import TIER_NAMES

SMALL = {"camera_width": 96, "camera_height": 72}


def test_bee_passes_the_single_capsule_where_straight_collides() -> None:
    env = gym.make("FlowNavSingle-v0")
    straight = run_episode(env, StraightAgent(), seed=0, label="straight")
    bee = run_episode(env, BeeAgent(), seed=0, label="bee")
    env.close()
    assert straight.collision and not straight.success
    assert bee.success and not bee.collision
    assert bee.min_clearance_m > 0.2
    # Straight flies the axis; bee slides sideways around the capsule, and the record keeps how far.
    assert straight.max_abs_lateral_m < 0.05 < bee.max_abs_lateral_m < 6.0


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
    mirrored, _ = BeeAgent().predict({"depth_histogram": histogram[:, ::-1].copy(), "state": state})
    # Slides right, by the centring gain's share of the nearness difference, and left when mirrored
    # (independent of the tuned gains' values).
    assert action[0] > 0.1 and mirrored[0] == pytest.approx(-action[0])
    assert sector_nearness(histogram, BeeAgent().bin_edges)[0, 0] == pytest.approx(2.0)


def test_unknown_agent_and_missing_policy_errors(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"agent must be one of .*got 'wasp'"):
        load_agent("wasp")
    with pytest.raises(FileNotFoundError, match=r"policy file for agent 'ppo_flow' not found"):
        load_agent("ppo_flow", tmp_path / "none.zip")


# A training seed of each agent behind the benchmark, and the lever search's winner, which reads the approach key.
SHIPPED = ("ppo_flow@0", "ppo_oracle@1", "ppo_robust@2", "ppo_flow_course_approach_curriculum_slow@3")


def test_shipped_policies_load_only_their_parameters_and_act_as_ppo_load(monkeypatch) -> None:
    from stable_baselines3 import PPO
    from stable_baselines3.common import save_util

    def unpickling_forbidden(*args, **kwargs):
        raise AssertionError("the policy's pickled data was read")

    for name in SHIPPED:
        with monkeypatch.context() as patch, warnings.catch_warnings():
            warnings.simplefilter("error", UnverifiedPolicyWarning)  # listed in the manifest with its hash
            patch.setattr(save_util, "json_to_data", unpickling_forbidden)
            agent = load_agent(name)
        reference = PPO.load(policy_file(name), device="cpu")
        env = gym.make("FlowNav-v0", **agent_env_kwargs(name))
        observation, _ = env.reset(seed=TEST_SEED_START)
        observations = [observation, env.step(np.zeros(3))[0]]
        env.observation_space.seed(0)
        observations += [env.observation_space.sample() for _ in range(3)]
        env.close()
        for observation in observations:
            ours, _ = agent.predict(observation, deterministic=True)
            theirs, _ = reference.predict(observation, deterministic=True)
            np.testing.assert_array_equal(ours, theirs)


def test_the_manifest_lists_every_shipped_policy_with_its_hash() -> None:
    from agents.common.locations import RESULTS_DIR

    # results/policies/ holds training seeds only; the single pre-seed policies are kept with the sweep that
    # flew them (results/sweep_thesis_range/policies/), where their manifest still vouches for them.
    assert not list(POLICIES_DIR.glob("*.zip"))
    folders = [p for p in POLICIES_DIR.iterdir() if p.is_dir()]
    folders.append(RESULTS_DIR / "sweep_thesis_range" / "policies")
    for folder in folders:
        manifest = read_manifest(folder / MANIFEST_NAME)
        assert sorted(manifest) == sorted(p.name for p in folder.glob("*.zip")), folder
        assert all(file_sha256(folder / name) == digest for name, digest in manifest.items()), folder


def test_every_learned_agent_ships_verified_training_seeds_that_fly_with_their_own_env() -> None:
    from agents.policies import LEARNED_AGENTS, trained_seeds

    for name in LEARNED_AGENTS:
        # An agent learned once per tier ships each tier's seeds in that tier's folder, on one tier at least.
        tiers = [t for t in TIER_NAMES if trained_seeds(name, tier=t)] if is_per_tier(name) else [None]
        assert tiers, name
        for tier_name in tiers:
            seeds = trained_seeds(name, tier=tier_name)
            assert len(seeds) >= 3 and (name == "ppo_robust" or len(seeds) >= 5), (name, tier_name, seeds)
            manifest = read_manifest(policy_folder(name, tier=tier_name) / MANIFEST_NAME)
            assert {f"seed_{k}.zip" for k in seeds} <= set(manifest), name
    # The winner reads the approach input it was trained on; its seeds act on a real env.
    winner = "ppo_flow_course_approach_curriculum_slow"
    assert agent_env_kwargs(f"{winner}@4")["observe_approach"] is True
    # its recipe on true depths reads the same inputs, the true depth at the same tracked points in place of flow's
    truth = agent_env_kwargs(f"{winner}_oracle@4")
    assert truth["observe_approach"] is True and truth["obs_source"] == "oracle"
    assert agent_env_kwargs(f"{winner}@4").get("obs_source", "flow") == "flow"
    env = gym.make("FlowNav-v0", **agent_env_kwargs(f"{winner}@0"), **SMALL)
    observation, _ = env.reset(seed=TEST_SEED_START)
    env.close()
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnverifiedPolicyWarning)
        actions = [load_agent(f"{winner}@{k}").predict(observation)[0] for k in trained_seeds(winner)]
    assert all(a.shape == (3,) and np.all(np.abs(a) <= 1.0) for a in actions)


def copy_policy(name: str, directory: Path, with_config: bool = True) -> Path:
    """A copy of the agent's first shipped training seed, as ``<directory>/<name>.zip``."""
    policy = directory / f"{name}.zip"
    shutil.copyfile(policy_file(name), policy)
    if with_config:
        shutil.copyfile(policy_file(name).with_suffix(".yaml"), policy.with_suffix(".yaml"))
    return policy


def test_policies_the_manifest_does_not_vouch_for_load_with_a_warning(tmp_path: Path) -> None:
    policy = copy_policy("ppo_flow", tmp_path)
    with pytest.warns(UnverifiedPolicyWarning, match=r"ppo_flow.zip is not beside a MANIFEST.sha256"):
        load_agent("ppo_flow", policy)
    (tmp_path / MANIFEST_NAME).write_text(f"{'0' * 64}  ppo_flow.zip\n")
    with pytest.warns(UnverifiedPolicyWarning, match=r"does not match its SHA-256 in .*MANIFEST.sha256"):
        load_agent("ppo_flow", policy)
    (tmp_path / MANIFEST_NAME).write_text(f"{file_sha256(policy)}  ppo_flow.zip\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnverifiedPolicyWarning)
        load_agent("ppo_flow", policy)
    bare = copy_policy("ppo_robust", tmp_path, with_config=False)
    with pytest.warns(
        UnverifiedPolicyWarning, match=r"ppo_robust.zip is not listed .*unpickled with PPO.load"
    ):
        load_agent("ppo_robust", bare, trust_pickle=True)


def rewrite_zip(source: Path, target: Path, replace: dict[str, bytes | None]) -> None:
    with zipfile.ZipFile(source) as original, zipfile.ZipFile(target, "w") as copy:
        for entry in original.namelist():
            content = replace.get(entry, original.read(entry))
            if content is not None:
                copy.writestr(entry, content)


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        ("not a zip", r"broken.zip is not a readable zip file \(cut short or not a model\)"),
        ("cut short", r"broken.zip is not a readable zip file \(cut short or not a model\)"),
        ("other zip", r"broken.zip is not a stable-baselines3 model: it lacks data, policy.pth"),
        ("cut JSON", r"broken.zip: its 'data' entry is not valid JSON \(file cut or edited\)"),
        ("bad weights", r"broken.zip: its policy.pth is not a weights-only parameter file"),
        ("other network", r"broken.zip: its parameters do not fit the network of the config beside it"),
    ],
)
def test_bad_policy_files_raise_value_errors_naming_the_file(
    tmp_path: Path, damage: str, message: str
) -> None:
    source, broken = policy_file("ppo_flow@0"), tmp_path / "broken.zip"
    shutil.copyfile(source.with_suffix(".yaml"), broken.with_suffix(".yaml"))
    if damage == "not a zip":
        broken.write_text("hello")
    elif damage == "cut short":
        broken.write_bytes(source.read_bytes()[:5000])
    elif damage == "other zip":
        with zipfile.ZipFile(broken, "w") as archive:
            archive.writestr("notes.txt", "not a policy")
    elif damage == "cut JSON":
        with zipfile.ZipFile(source) as archive:
            data = archive.read("data")
        rewrite_zip(source, broken, {"data": data[: len(data) // 2]})
    elif damage == "bad weights":
        rewrite_zip(source, broken, {"policy.pth": b"not weights"})
    else:
        shutil.copyfile(source, broken)
        config = yaml.safe_load(source.with_suffix(".yaml").read_text())
        config["ppo"]["net_arch"] = [16]
        rewrite_zip(source, broken, {"data": None})
        with zipfile.ZipFile(broken, "a") as archive:
            archive.writestr("data", "{}")
        broken.with_suffix(".yaml").write_text(yaml.safe_dump(config))
    with pytest.raises(ValueError, match=message):
        load_agent("ppo_flow", broken)


def test_policies_resolve_against_the_repository_not_the_current_directory(
    tmp_path: Path, monkeypatch
) -> None:
    monkeypatch.chdir(tmp_path)
    # An agent named alone stands for its first shipped training seed where one file must.
    assert policy_file("ppo_flow") == POLICIES_DIR / "ppo_flow" / "seed_0.zip"
    assert policy_file("ppo_flow").is_absolute()
    assert agent_env_kwargs("ppo_oracle") == {"obs_source": "oracle"}
    assert hasattr(load_agent("ppo_flow"), "predict")


def test_load_policy_gives_the_env_the_policy_was_trained_for() -> None:
    loaded = load_policy(POLICIES_DIR / "ppo_oracle" / "seed_0.zip")
    assert isinstance(loaded, LoadedPolicy)
    assert (loaded.env_id, loaded.env_kwargs) == ("FlowNav-v0", {"obs_source": "oracle"})
    env = gym.make(loaded.env_id, **loaded.env_kwargs, **SMALL)
    assert env.unwrapped.obs_source == "oracle"
    observation, _ = env.reset(seed=TEST_SEED_START)
    action, _ = loaded.agent.predict(observation, deterministic=True)
    env.close()
    assert action.shape == (3,)
    made = loaded.make_env(brightness=0.5)
    assert made.unwrapped.obs_source == "oracle" and made.unwrapped.brightness == 0.5
    made.close()


def test_load_policy_needs_the_config_beside_the_zip(tmp_path: Path) -> None:
    bare = copy_policy("ppo_oracle", tmp_path, with_config=False)
    with pytest.raises(FileNotFoundError, match=r"no training config beside .*ppo_oracle.zip"):
        load_policy(bare)
    with pytest.raises(FileNotFoundError, match=r"policy file not found: .*none.zip"):
        load_policy(tmp_path / "none.zip")


def _observation(near_columns: slice, *, heading: float = 0.0, unresolved: float = 0.0) -> dict:
    histogram = np.zeros((3, 5, 6), np.float32)
    histogram[:2, :, 5] = 1.0  # far everywhere...
    histogram[:2, near_columns] = 0.0
    histogram[:2, near_columns, 0] = 1.0  # ...but within 1 m in these columns
    state = np.array([1.0, 0, 0, 0, 0, 1.0, heading], np.float32)
    return {
        "depth_histogram": histogram,
        "state": state,
        "unresolved": np.full((3, 5), unresolved, np.float32),
    }


@pytest.mark.parametrize("name", ["bee_robust", "bee_ttc", "vfh"])
def test_strong_reactive_agents_steer_away_from_the_near_side(name: str) -> None:
    agent = load_agent(name)
    left_blocked, _ = agent.predict(_observation(slice(0, 3)))
    right_blocked, _ = agent.predict(_observation(slice(2, 5)))
    assert left_blocked[0] > 0.3 and right_blocked[0] < -0.3  # positive lateral is to the right
    batch = {k: np.stack([v, v]) for k, v in _observation(slice(0, 3)).items()}
    assert agent.predict(batch)[0].shape == (2, 3)


def test_vfh_heads_for_the_goal_when_the_way_is_free() -> None:
    # Heading error +0.5 rad: the drone points left of the goal, which lies to its right.
    action, _ = load_agent("vfh").predict(_observation(slice(0, 0), heading=0.5))
    assert action[0] > 0 and action[2] > 0  # slide and turn right


def test_robust_nearness_ignores_a_lone_outlier_and_counts_unresolved_points_as_far() -> None:
    from agents.policies import quantile_nearness, sector_nearness

    edges = np.asarray(BeeAgent().bin_edges)
    histogram = np.zeros((1, 6))
    histogram[0, 0], histogram[0, 5] = 0.1, 0.9  # one near outlier among far points
    far_only = np.zeros((1, 6))
    far_only[0, 5] = 1.0
    robust = quantile_nearness(histogram, np.zeros(1), edges, 0.5)[0]
    assert robust == quantile_nearness(far_only, np.zeros(1), edges, 0.5)[0]  # the outlier changes nothing
    assert sector_nearness(histogram, edges)[0] > 4 * robust  # while it quadruples the mean
    near = np.zeros((1, 6))
    near[0, 0] = 1.0
    assert quantile_nearness(near, np.zeros(1), edges, 0.5)[0] > 1.0
    assert quantile_nearness(near, np.full(1, 0.8), edges, 0.5)[0] == 0.0  # mostly unresolved: far


def test_robust_bee_smooths_over_frames_and_restarts_each_episode() -> None:
    agent = load_agent("bee_robust", smoothing=0.5)
    _, memory = agent.predict(_observation(slice(0, 3)), episode_start=np.ones(1, bool))
    _, blended = agent.predict(_observation(slice(0, 0)), state=memory, episode_start=np.zeros(1, bool))
    _, fresh = agent.predict(_observation(slice(0, 0)), state=memory, episode_start=np.ones(1, bool))
    np.testing.assert_allclose(blended, 0.5 * memory + 0.5 * fresh)
    with pytest.raises(ValueError, match=r"smoothing must be in \(0, 1\], got 0"):
        load_agent("bee_robust", smoothing=0)
    assert agent_env_kwargs("vfh") == {"observe_unresolved": True}


def test_strong_reactive_agents_fly_a_real_episode() -> None:
    for name in ("bee_robust", "bee_ttc", "vfh"):
        env = gym.make("FlowNavSingle-v0", observe_unresolved=True, **SMALL)
        record = run_episode(env, load_agent(name), seed=0, label=name)
        env.close()
        assert record.steps > 5 and record.agent == name


def test_bee_ttc_is_bee_robust_at_its_reference_speed_and_reacts_earlier_when_faster() -> None:
    def at_speed(speed: float) -> dict:
        observation = _observation(slice(0, 2))  # something within 1 m on the left
        observation["state"] = observation["state"].copy()
        observation["state"][0] = speed
        return observation

    robust, ttc = load_agent("bee_robust"), load_agent("bee_ttc")
    assert {k: v for k, v in agent_parameters("bee_ttc").items() if k != "reference_speed_mps"} == (
        agent_parameters("bee_robust")
    )
    np.testing.assert_allclose(ttc.predict(at_speed(1.0))[0], robust.predict(at_speed(1.0))[0])
    # Twice as fast, half the time to contact: it slides away harder, while bee_robust does not change.
    assert ttc.predict(at_speed(2.0))[0][0] > ttc.predict(at_speed(1.0))[0][0] > 0
    np.testing.assert_allclose(robust.predict(at_speed(2.0))[0], robust.predict(at_speed(1.0))[0])
    # Its memory holds the nearness, not the scaled rate, so the speed never leaks across frames.
    np.testing.assert_allclose(ttc.predict(at_speed(2.0))[1], robust.predict(at_speed(2.0))[1])
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="reference_speed_mps must be a finite speed > 0 m/s, got"):
            load_agent("bee_ttc", reference_speed_mps=bad)
    assert agent_env_kwargs("bee_ttc") == {"observe_unresolved": True}
