"""``flownav video``: an mp4 from the declared dependencies (imageio's ffmpeg, no moviepy), from any directory."""

from __future__ import annotations

from pathlib import Path

import imageio.v2 as imageio
import pytest


def test_video_of_a_shipped_policy_from_outside_the_repository(tmp_path: Path, monkeypatch, capsys) -> None:
    from agents.cli import main

    monkeypatch.chdir(tmp_path)  # the policy must still resolve to the repository's results/policies/
    out = tmp_path / "ppo_flow.mp4"
    args = ["video", "--agent", "ppo_flow", "--env-id", "FlowNavSingle-v0", "--max-steps", "3"]
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
