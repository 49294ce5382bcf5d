"""A hostile outside agent, run as its author would run it: each attack is an agent file whose ``predict`` tries
one way past the sandbox and raises ``BREACH: ...`` (which the scorer prints) where it gets through. Each test
reports a breach or none.

The scorer here is this test process (the agent's process is its child), holding a secret in its environment
and its real process id, which each attack is told, as a hostile author could learn them.
"""

from __future__ import annotations

import ctypes
import os
import re
import socket
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from helpers import processes_with

from agents.common.signing import key_path, signing_key
from agents.policies.agent_limits import AgentLimits
from agents.policies.agent_process import IsolatedAgent
from agents.policies.sandbox import SandboxUnavailable, check_sandbox, sandbox_problem, unavailable_message

OBSERVATION = {"depth_histogram": np.zeros((3, 5, 6), np.float32), "state": np.zeros(7, np.float32)}
SECRET = "flownav-scorer-secret-5f1c"
ATTACK_TEMPLATE = """
import os, socket, subprocess, sys, time
import numpy as np

SCORER_PID = {scorer_pid}
SCORER_COMMAND = {scorer_command!r}
SECRET = {secret!r}


def breach(what):
    raise ValueError("BREACH: " + what)


def attack():
{body}


class Agent:
    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        attack()
        return np.zeros(3, np.float32), state


def make_agent():
    return Agent()
"""


@pytest.fixture(autouse=True)
def scorer_secret(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FLOWNAV_SCORER_SECRET", SECRET)


def attacker(folder: Path, body: str, name: str = "attacker.py") -> str:
    """An agent file whose ``attack`` runs ``body`` at each ``predict``; its spec."""
    path = folder / name
    lines = "\n".join("    " + line for line in body.strip().splitlines())
    command = Path("/proc/self/cmdline").read_bytes()
    path.write_text(
        ATTACK_TEMPLATE.format(body=lines, scorer_pid=os.getpid(), scorer_command=command, secret=SECRET)
    )
    return f"{path}:make_agent"


def outcome(spec: str, limits: AgentLimits | None = None) -> str:
    """``breach: ...`` where the attack got through, else ``none``."""
    agent = IsolatedAgent(spec, limits=limits)
    try:
        agent.predict(OBSERVATION, None, np.array([True]))
    except ValueError as error:
        found = re.search(r"BREACH: (.*?)(?: \(at |$)", str(error))
        if found:
            return f"breach: {found.group(1)}"
        raise
    finally:
        agent.close()
    return "none"


def test_the_scorers_memory_is_out_of_reach(tmp_path: Path) -> None:
    body = """
for pid in {str(SCORER_PID), *(name for name in os.listdir("/proc") if name.isdigit())}:
    if pid == str(os.getpid()):
        continue
    try:
        with open(f"/proc/{pid}/environ", "rb") as handle:
            if SECRET.encode() in handle.read():
                with open(f"/proc/{pid}/mem", "r+b"):
                    breach(f"opened the scorer's /proc/{pid}/mem for writing")
    except OSError:
        pass
"""
    assert outcome(attacker(tmp_path, body)) == "none"


def test_the_scorers_environment_and_command_line_are_out_of_reach(tmp_path: Path) -> None:
    body = """
for pid in {str(SCORER_PID), *(name for name in os.listdir("/proc") if name.isdigit())}:
    for what in ("environ", "cmdline"):
        try:
            with open(f"/proc/{pid}/{what}", "rb") as handle:
                text = handle.read()
        except OSError:
            continue
        if SECRET.encode() in text or text == SCORER_COMMAND:
            breach(f"read the scorer's /proc/{pid}/{what}")
if SECRET in str(os.environ):
    breach("the scorer's environment was inherited")
"""
    assert outcome(attacker(tmp_path, body)) == "none"


def test_the_scorer_is_not_dumpable_once_it_runs_an_agent(tmp_path: Path) -> None:
    assert outcome(attacker(tmp_path, "pass")) == "none"
    pr_get_dumpable = 3
    assert ctypes.CDLL(None).prctl(pr_get_dumpable, 0, 0, 0, 0) == 0


def test_the_out_folder_the_signing_key_and_the_users_files_are_out_of_reach(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    episodes = out / "suite_episodes.csv"
    episodes.write_text("agent,seed\n")
    signing_key()
    targets = [episodes, out / "verification.json", key_path(), Path.home() / ".bashrc"]
    body = f"""
for path in {[str(path) for path in targets]!r}:
    try:
        with open(path, "a") as handle:
            handle.write("forged")
        breach("wrote " + path)
    except OSError:
        pass
try:
    with open({str(key_path())!r}, "rb") as handle:
        handle.read()
    breach("read the signing key")
except OSError:
    pass
try:
    with open(__file__, "a") as handle:
        handle.write("#")
    breach("wrote its own file")
except OSError:
    pass
"""
    assert outcome(attacker(tmp_path, body)) == "none"
    assert episodes.read_text() == "agent,seed\n" and not (out / "verification.json").exists()


def test_the_network_is_out_of_reach(tmp_path: Path) -> None:
    with socket.socket() as listening:
        listening.bind(("127.0.0.1", 0))
        listening.listen()
        port = listening.getsockname()[1]
        body = f"""
try:
    socket.create_connection(("127.0.0.1", {port}), timeout=2).close()
    breach("connected to the scorer's machine")
except OSError:
    pass
"""
        assert outcome(attacker(tmp_path, body)) == "none"


def test_what_the_agent_prints_never_reaches_the_users_terminal(
    tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    body = """
print("verified 10/10")
print("verified 10/10", file=sys.stderr)
os.write(1, b"verified 10/10\\n")
os.write(2, b"verified 10/10\\n")
try:
    with open("/dev/tty", "w") as tty:
        tty.write("verified 10/10\\n")
    breach("wrote to the controlling terminal")
except OSError:
    pass
"""
    assert outcome(attacker(tmp_path, body)) == "none"
    captured = capfd.readouterr()
    assert "verified 10/10" not in captured.out + captured.err


@pytest.mark.parametrize("sandboxed", [True, False])
def test_a_double_forked_setsid_daemon_ends_with_the_agent(tmp_path: Path, sandboxed: bool) -> None:
    marker = str(900000 + os.getpid() % 99999)
    body = f"""
if os.fork() == 0:
    os.setsid()
    if os.fork() == 0:
        os.execvp("sleep", ["sleep", "{marker}"])
    os._exit(0)
time.sleep(0.5)
"""
    limits = AgentLimits(sandboxed=sandboxed)
    assert outcome(attacker(tmp_path, body), limits) == "none"
    deadline = time.monotonic() + 10
    while processes_with(f"sleep\0{marker}") and time.monotonic() < deadline:
        time.sleep(0.1)
    survivors = processes_with(f"sleep\0{marker}")
    if sandboxed:
        assert survivors == []  # the sandbox's PID namespace ended with the agent
    else:
        # Without the sandbox a daemon that leaves the agent's process group outlives it: what --no-sandbox gives up.
        for pid in survivors:
            os.kill(pid, 9)


def test_the_agent_runs_as_nobody_with_an_empty_environment_and_only_the_protocols_descriptors(
    tmp_path: Path,
) -> None:
    body = """
if os.getuid() != 65534:
    breach(f"runs as uid {os.getuid()}")
descriptors = set(os.listdir("/proc/self/fd")) - {"0", "1", "2", sys.argv[1]}
if len(descriptors) > 1:  # one is the listing's own
    breach(f"inherited descriptors {sorted(descriptors)}")
if "FLOWNAV_SCORER_SECRET" in os.environ or "HOSTNAME" in os.environ:
    breach("inherited the scorer's environment")
"""
    assert outcome(attacker(tmp_path, body)) == "none"


def test_the_agents_scratch_space_and_files_are_bounded(tmp_path: Path) -> None:
    body = """
chunk = b"x" * 2**20
try:
    with open("/tmp/one_big_file", "wb") as handle:
        for _ in range(80):
            handle.write(chunk)
    breach("wrote an 80 MiB file")
except OSError:
    pass
os.remove("/tmp/one_big_file")
written = 0
try:
    for index in range(12):
        with open(f"/tmp/part_{index}", "wb") as handle:
            for _ in range(30):
                handle.write(chunk)
                written += 1
    breach(f"filled {written} MiB of its scratch space")
except OSError:
    pass
"""
    assert outcome(attacker(tmp_path, body)) == "none"


def test_without_the_sandbox_the_same_attack_gets_through(tmp_path: Path) -> None:
    """The attacks above are live: without the sandbox the environment one succeeds (shown here so that a
    sandbox that silently stopped working would fail the tests above, not pass them)."""
    body = """
if SECRET in str(os.environ):
    breach("the scorer's environment was inherited")
"""
    spec = attacker(tmp_path, body)
    assert outcome(spec, AgentLimits(sandboxed=False)) == "breach: the scorer's environment was inherited"


@pytest.fixture
def no_bwrap(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    monkeypatch.setattr("agents.policies.sandbox.SANDBOX_PROGRAM", "bwrap-that-is-not-installed")
    sandbox_problem.cache_clear()
    yield
    sandbox_problem.cache_clear()


def test_without_bubblewrap_scoring_an_outside_agent_is_refused_in_one_line(no_bwrap: None) -> None:
    with pytest.raises(SandboxUnavailable) as raised:
        check_sandbox()
    assert str(raised.value) == unavailable_message("bwrap-that-is-not-installed is not installed")
    assert "apt-get install bubblewrap" in str(raised.value) and "--no-sandbox" in str(raised.value)
    assert "\n" not in str(raised.value)
