"""``flownav video``: an mp4 from the declared dependencies (imageio's ffmpeg, no moviepy), from any directory."""

from __future__ import annotations

from pathlib import Path

import imageio.v2 as imageio
import numpy as np
import pytest


def test_video_of_a_shipped_policy_from_outside_the_repository(tmp_path: Path, monkeypatch, capsys) -> None:
    from agents.cli import main

    monkeypatch.chdir(tmp_path)  # the policy must still resolve to the repository's results/policies/
    out = tmp_path / "ppo_flow.mp4"
    args = ["video", "--agent", "ppo_flow", "--tiers", "FlowNavSingle-v0", "--max-steps", "3"]
    assert main([*args, "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert f"wrote {out}" in captured.out and "warning" not in captured.err  # a shipped, verified policy
    assert (
        "this video flies ppo_flow@0" in captured.out
    )  # the first training seed, not the pre-seed ppo_flow.zip
    with imageio.get_reader(out) as reader:
        assert sum(1 for _ in reader) == 3


def test_commands_that_load_a_policy_say_what_loading_risks(capsys) -> None:
    from agents.cli import main

    for command in ("video", "train"):
        with pytest.raises(SystemExit):
            main([command, "--help"])
        assert "unpickles" in " ".join(capsys.readouterr().out.split())


def test_a_video_carries_the_agents_memory_from_step_to_step(tmp_path: Path, monkeypatch) -> None:
    # A frame-stacked or recurrent policy keeps its memory in predict's state, told where the episode starts.
    from agents.studies import video

    calls = []

    class Remembering:
        def predict(self, observation, state=None, episode_start=None, deterministic=True):
            calls.append((state, None if episode_start is None else bool(np.asarray(episode_start).any())))
            return np.zeros(3, np.float32), len(calls)

    monkeypatch.setattr(video, "load_agent", lambda *args, **kwargs: Remembering())
    video.record_episode("bee", "FlowNavSingle-v0", 0, tmp_path / "m.mp4", max_steps=4)
    assert calls == [(None, True), (1, False), (2, False), (3, False)]
