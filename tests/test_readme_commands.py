"""The README's two opening commands: CI must run the test command exactly as the README writes it."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def readme_commands() -> dict[str, str]:
    """The README's first bash block as {comment above a command: the command}."""
    text = (ROOT / "README.md").read_text()
    block = re.search(r"```bash\n(.*?)```", text, re.S)
    assert block is not None, "README.md has no bash block"
    commands: dict[str, str] = {}
    comment = ""
    for line in block.group(1).splitlines():
        if line.startswith("#"):
            comment = line.lstrip("# ").strip()
        elif line.strip():
            commands[comment] = line.strip()
    return commands


def test_the_readme_opens_with_an_install_and_run_command_and_a_test_command() -> None:
    commands = readme_commands()
    assert len(commands) == 2
    main_job, tests = commands.values()
    assert main_job.startswith("pip install") and "flownav" in main_job
    # The tests install the sandbox outside agents fly in (bubblewrap) before the package.
    assert "bubblewrap" in tests and "&& pip install" in tests and tests.endswith("&& pytest")


def test_ci_runs_the_readme_test_command_verbatim() -> None:
    test_command = list(readme_commands().values())[1]
    ci_lines = [line.strip() for line in (ROOT / ".ci" / "run").read_text().splitlines()]
    assert test_command in ci_lines, f"CI does not run the README's test command {test_command!r} as written"
