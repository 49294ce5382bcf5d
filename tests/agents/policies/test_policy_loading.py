"""Loading a policy never unpickles without an opt-in, a learned agent named alone flies its shipped
training seeds in turn, and an env lacking an observation key a policy reads fails in one line."""

from __future__ import annotations

import base64
import json
import os
import pickle
import re
import shutil
import warnings
import zipfile
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import flownav_env  # noqa: F401
from agents.common.locations import POLICIES_DIR
from agents.common.seeds import TEST_SEED_START
from agents.evaluation.episode import run_episode
from agents.policies import (
    OBSERVATION_KEY_SETTINGS,
    TrainingSeedsAgent,
    UnverifiedPolicyWarning,
    agent_env_kwargs,
    load_agent,
    policy_file,
    shipped_seed_runs,
)

SMALL = {"camera_width": 96, "camera_height": 72}
WINNER = "ppo_flow_course_approach_curriculum_slow"


class _MakesADirectory:
    """Unpickling this runs ``os.mkdir(path)``: a harmless stand-in for the shell command a crafted zip runs."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def __reduce__(self):
        return (os.mkdir, (str(self.path),))


def crafted_policy(directory: Path, marker: Path) -> Path:
    """A real policy zip whose ``data`` names code to run when unpickled, with no training config beside it."""
    source, crafted = policy_file("ppo_flow@0"), directory / "crafted.zip"
    with zipfile.ZipFile(source) as original:
        entries = {name: original.read(name) for name in original.namelist()}
    data = json.loads(entries["data"])
    data["observation_space"][":serialized:"] = base64.b64encode(
        pickle.dumps(_MakesADirectory(marker))
    ).decode()
    entries["data"] = json.dumps(data).encode()
    with zipfile.ZipFile(crafted, "w") as archive:
        for name, content in entries.items():
            archive.writestr(name, content)
    return crafted


def test_a_zip_without_its_config_is_refused_before_anything_in_it_is_read(
    tmp_path: Path, monkeypatch
) -> None:
    from stable_baselines3 import PPO

    from agents.policies import loading

    marker = tmp_path / "code_ran"
    crafted = crafted_policy(tmp_path, marker)

    def nothing_may_be_read(*args, **kwargs):
        raise AssertionError("the zip was opened before the refusal")

    with monkeypatch.context() as patch:
        patch.setattr(PPO, "load", nothing_may_be_read)
        patch.setattr(loading, "read_saved_model", nothing_may_be_read)
        config = re.escape(str(tmp_path / "crafted.yaml"))
        expected = (
            rf"^{re.escape(str(crafted))} has no training config beside it \(expected {config}\), and loading "
            r"it without one would unpickle it, which runs any code the file holds: put the training config it "
            rf"was trained with at {config}, or, for a file you trust, pass --trust-pickle "
            r"\(trust_pickle=True in Python\)$"
        )
        with pytest.raises(ValueError, match=expected):
            load_agent("ppo_flow", crafted)
    assert not marker.exists()
    # The opt-in is what runs its code: the crafted file is no stand-in for a harmless one.
    with (
        pytest.raises(ValueError, match=r"crafted.zip could not be loaded as a PPO model"),
        warnings.catch_warnings(),
    ):
        warnings.simplefilter("ignore", UnverifiedPolicyWarning)
        load_agent("ppo_flow", crafted, trust_pickle=True)
    assert marker.is_dir()


def test_trusted_pickles_load_and_still_check_their_observation_keys(tmp_path: Path) -> None:
    bare = tmp_path / "seed_0.zip"
    shutil.copyfile(policy_file(f"{WINNER}@0"), bare)
    with pytest.warns(
        UnverifiedPolicyWarning, match=r"seed_0.zip is not beside a MANIFEST.sha256 .*unpickled"
    ):
        agent = load_agent(WINNER, bare, trust_pickle=True)
    env = gym.make("FlowNav-v0", **SMALL)
    observation, _ = env.reset(seed=TEST_SEED_START)
    env.close()
    message = (
        rf"^policy {re.escape(str(bare))} reads observation key 'approach', which this env does not give: make "
        r"the env with observe_approach=True \(no training config beside it says which env it was trained with\)$"
    )
    with pytest.raises(ValueError, match=message):
        agent.predict(observation)


def test_video_refuses_a_zip_without_its_config_unless_trusted(tmp_path: Path, monkeypatch, capsys) -> None:
    from agents.cli import main

    monkeypatch.chdir(tmp_path)
    bare = tmp_path / "bare.zip"
    shutil.copyfile(policy_file("ppo_flow@0"), bare)
    args = ["video", "--agent", "ppo_flow", "--policy", str(bare), "--tiers", "FlowNavSingle-v0"]
    args += ["--max-steps", "2", "--out", str(tmp_path / "v.mp4")]
    assert main(args) == 2
    error = capsys.readouterr().err
    assert (
        error.startswith(f"flownav video: error: {bare} has no training config beside it")
        and "--trust-pickle" in error
    )
    assert error.count("\n") == 1 and not (tmp_path / "v.mp4").exists()
    assert main([*args, "--trust-pickle"]) == 0
    assert (tmp_path / "v.mp4").is_file()


def test_an_agent_named_alone_flies_its_shipped_seeds_one_episode_each_in_turn() -> None:
    runs = shipped_seed_runs("ppo_flow")
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnverifiedPolicyWarning)  # the shipped, verified seeds
        agent = load_agent("ppo_flow")
        seeds = {name: load_agent(name) for name in runs}
    assert isinstance(agent, TrainingSeedsAgent) and agent.run_names == runs and len(runs) >= 2
    env = gym.make("FlowNav-v0", **SMALL)
    observation, _ = env.reset(seed=TEST_SEED_START)
    observation, *_ = env.step(np.zeros(3))
    env.close()
    observation["state"][-1] = 0.4  # off the goal's heading, so the seeds disagree
    flown = []
    for episode in range(len(runs) + 2):
        action, _ = agent.predict(observation, episode_start=np.ones(1, bool))
        flown.append(agent.current_run)
        np.testing.assert_array_equal(action, seeds[agent.current_run].predict(observation)[0])
        agent.predict(observation, episode_start=np.zeros(1, bool))  # within the episode: the same seed
        assert agent.current_run == flown[-1], episode
    assert flown == [*runs, *runs[:2]]
    assert len({tuple(seeds[name].predict(observation)[0]) for name in runs}) > 1


def test_the_winner_loads_by_name_and_flies_run_episodes_seed_by_seed() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnverifiedPolicyWarning)
        agent = load_agent(WINNER)  # was a FileNotFoundError: no single results/policies/<agent>.zip
    shipped = sorted(
        int(path.stem.removeprefix("seed_")) for path in (POLICIES_DIR / WINNER).glob("seed_*.zip")
    )
    assert len(shipped) >= 10 and agent.run_names == [f"{WINNER}@{k}" for k in shipped]
    env = gym.make("FlowNavSingle-v0", **agent_env_kwargs(WINNER), **SMALL)
    flown = []
    for seed in (0, 1):
        assert run_episode(env, agent, seed=seed).steps >= 1
        flown.append(agent.current_run)
    env.close()
    assert flown == [f"{WINNER}@0", f"{WINNER}@1"]  # run_episode tells it where each episode starts


@pytest.mark.parametrize(
    ("name", "policy"),
    [
        (f"{WINNER}@0", None),
        (WINNER, None),  # every seed reads it; a refused episode leaves the turn with seed 0
        (
            "ppo_flow",
            POLICIES_DIR / "ppo_flow_course_approach_stack4" / "seed_0.zip",
        ),  # a frame-stacked policy
    ],
)
def test_an_env_without_a_key_the_policy_reads_fails_in_one_line(name: str, policy: Path | None) -> None:
    agent = load_agent(name, policy)
    env = gym.make("FlowNav-v0", **SMALL)  # no observe_approach
    expected_policy = policy or policy_file(f"{WINNER}@0")
    message = (
        rf"^policy {re.escape(str(expected_policy))} reads observation key 'approach', which this env does not "
        r"give: make the env with observe_approach=True \(the settings it was trained with are in "
        rf"{re.escape(str(expected_policy.with_suffix('.yaml')))}; .*make_env\(\) makes that env\)$"
    )
    with pytest.raises(ValueError, match=message):
        run_episode(env, agent, seed=TEST_SEED_START)
    env.close()
    if isinstance(agent, TrainingSeedsAgent):
        assert agent.current_run is None


def test_every_optional_observation_key_is_mapped_to_the_env_setting_that_gives_it() -> None:
    def keys(**settings: bool) -> set[str]:
        env = gym.make("FlowNav-v0", **settings, **SMALL)
        try:
            return set(env.observation_space.spaces)
        finally:
            env.close()

    plain = keys()
    for key, setting in OBSERVATION_KEY_SETTINGS.items():
        assert keys(**{setting: True}) - plain == {key}, setting
    everything = keys(**dict.fromkeys(OBSERVATION_KEY_SETTINGS.values(), True))
    assert everything - plain == set(OBSERVATION_KEY_SETTINGS)


def test_an_agent_named_alone_needs_shipped_seeds_that_share_their_env(tmp_path: Path, monkeypatch) -> None:
    import yaml

    from agents.policies import learned

    monkeypatch.setattr(learned, "POLICIES_DIR", tmp_path)  # a checkout with no policies
    with pytest.raises(
        FileNotFoundError,
        match=rf"^nothing to fly for ppo_flow: no policy at {re.escape(str(tmp_path))}/ppo_flow/seed_<k>.zip or "
        r".*ppo_flow.zip \(train it first: flownav train --seeds\)$",
    ):
        load_agent("ppo_flow")
    (tmp_path / "ppo_flow").mkdir()
    for seed, source in ((0, "ppo_flow@0"), (1, "ppo_oracle@1")):  # an oracle policy among flow seeds
        target = tmp_path / "ppo_flow" / f"seed_{seed}.zip"
        shutil.copyfile(policy_file(source), target)
        shutil.copyfile(policy_file(source).with_suffix(".yaml"), target.with_suffix(".yaml"))
    config = yaml.safe_load((tmp_path / "ppo_flow" / "seed_1.yaml").read_text())
    assert config["env"] == {"obs_source": "oracle"}
    with pytest.raises(
        ValueError,
        match=r"^the training seeds of ppo_flow in .* were trained with different env "
        r"settings \(.*\): name one, such as ppo_flow@0$",
    ):
        load_agent("ppo_flow")
