"""The sandbox an outside agent's process runs in: bubblewrap (``bwrap``, the sandbox behind Flatpak).

The agent's process gets new user, PID, mount, network, IPC and UTS namespaces; inside it is uid ``nobody``, sees
a read-only view of only what it needs (the Python installation and its site-packages, FlowNav's own packages
and configs, the agent's own file, package or model) and a private, empty ``/tmp`` as its scratch space, starts
with an empty environment, holds no file descriptor but the protocol's socket, and dies with the process that
started it. Its PID namespace ends with it: whatever it forked, ``setsid`` or not, ends too.

What it cannot reach, it cannot change: the scorer's files (``--out``, the key that signs verifications), the
scorer's ``/proc`` (its memory, environment and command line), the network. The scoring process also makes itself
non-dumpable (:func:`make_undumpable`), so even a same-user process outside any sandbox cannot read or write its
memory through ``/proc``.
"""

from __future__ import annotations

import ctypes
import functools
import importlib.machinery
import os
import shutil
import site
import subprocess
import sys
from collections.abc import Iterable, Sequence
from pathlib import Path

from agents.common.locations import CONFIGS_DIR, REPO_ROOT
from agents.policies.agent_limits import NO_SANDBOX_OPTION
from agents.policies.sb3_models import is_sb3_model_name

SANDBOX_PROGRAM = "bwrap"
INSTALL_HINT = (
    "install bubblewrap (Debian/Ubuntu: apt-get install bubblewrap; Fedora: dnf install bubblewrap; Arch: "
    "pacman -S bubblewrap)"
)
# The unprivileged user and group the agent runs as inside its user namespace.
NOBODY = 65534
# The scratch folder inside the sandbox: a private tmpfs, empty at start, gone at the end, and bounded (a tmpfs
# lives in memory, which the address-space limit does not count).
SCRATCH = "/tmp"
SCRATCH_BYTES = 256 * 2**20
# Environment variables passed into the sandbox when set here: none is a secret, and some OpenBLAS builds crash
# on some CPUs without the first two.
PASSED_ENVIRONMENT = (
    "OPENBLAS_CORETYPE",
    "OPENBLAS_L2_SIZE",
    "OMP_NUM_THREADS",
    "OPENBLAS_NUM_THREADS",
    "MKL_NUM_THREADS",
)
# FlowNav's own code and the tables it reads on import, as an editable install finds them.
FLOWNAV_PATHS = (REPO_ROOT / "agents", REPO_ROOT / "flownav_env", REPO_ROOT / "estimator", CONFIGS_DIR)
# Shared libraries' lookup cache: without it the loader misses multiarch folders such as /usr/lib/x86_64-linux-gnu.
SYSTEM_FILES = (Path("/etc/ld.so.cache"), Path("/etc/ld.so.conf"), Path("/etc/ld.so.conf.d"))
# prctl(PR_SET_DUMPABLE, 0): the process's memory and /proc entries are closed to same-user processes.
PR_SET_DUMPABLE = 4
# How long the probe that checks the sandbox works may take.
PROBE_TIMEOUT_S = 60.0


class SandboxUnavailable(ValueError):
    """The sandbox cannot run here: one line saying why and how to install it, or how to fly without it. A
    ValueError: ``flownav`` prints it as one line and exits 2."""


def unavailable_message(why: str) -> str:
    """The one line that refuses to score an outside agent without its sandbox."""
    return (
        f"an outside agent runs in a sandbox, and the sandbox cannot run here ({why}): {INSTALL_HINT}; or pass "
        f"{NO_SANDBOX_OPTION} to fly it without one (its rows then say so)"
    )


def python_paths() -> list[Path]:
    """The Python installation and every site-packages folder this process imports from."""
    paths = {Path(sys.prefix), Path(sys.base_prefix), Path(sys.exec_prefix), Path(sys.executable).parent}
    paths.update(Path(entry) for entry in site.getsitepackages())
    user_site = site.getusersitepackages()
    if user_site and Path(user_site).is_dir():
        paths.add(Path(user_site))
    # Folders on sys.path that hold installed packages (a .pth, a .dist-info), not the current folder.
    for entry in sys.path:
        folder = Path(entry) if entry else None
        if folder is not None and folder.is_dir() and folder.name in ("site-packages", "dist-packages"):
            paths.add(folder)
    return sorted(path.resolve() for path in paths if path.exists())


def module_paths(module: str) -> tuple[list[Path], list[Path]]:
    """Where the top-level module of ``module`` (``my_pkg`` of ``my_pkg.sub``) lives, found without importing it:
    the paths to show the sandbox (its package folder or its file) and the sys.path entry it sits in."""
    top = module.partition(".")[0]
    spec = importlib.machinery.PathFinder.find_spec(top)
    if spec is None:
        return [], []
    if spec.submodule_search_locations:
        folders = [Path(location).resolve() for location in spec.submodule_search_locations]
        return folders, [folder.parent for folder in folders]
    if spec.origin:
        origin = Path(spec.origin).resolve()
        return [origin], [origin.parent]
    return [], []


def agent_paths(spec: str) -> tuple[list[Path], list[Path]]:
    """What the agent ``spec`` needs to read (its file, its package, its model zip and the config beside it), and
    the folders its process imports from; neither holds anything of the scorer's."""
    if is_sb3_model_name(spec):  # <algo>:<model.zip>
        model = Path(str(spec).partition(":")[2]).resolve()
        return [model, model.with_suffix(".yaml")], []
    target = str(spec).rpartition(":")[0]
    if target.endswith(".py") or "/" in target:
        return [Path(target).resolve()], []
    return module_paths(target)


def sandbox_environment(python_path: Sequence[Path] = ()) -> dict[str, str]:
    """The whole environment of the sandbox, and of ``bwrap`` itself (whose process the agent can see inside
    it): nothing of the scorer's but a few variables that tune numerical libraries."""
    environment = {
        "HOME": SCRATCH,
        "TMPDIR": SCRATCH,
        "LANG": "C.UTF-8",
        "PATH": "/usr/bin:/bin",
        "PYTHONUNBUFFERED": "1",  # what the agent prints reaches its log as it prints it
    }
    environment.update({name: os.environ[name] for name in PASSED_ENVIRONMENT if name in os.environ})
    paths = [str(path) for path in (*python_path, REPO_ROOT)]
    environment["PYTHONPATH"] = os.pathsep.join(dict.fromkeys(paths))
    return environment


def sandbox_command(
    command: Sequence[str], readable: Iterable[Path], *, python_path: Sequence[Path] = ()
) -> list[str]:
    """``command`` run inside the sandbox, which shows it ``readable`` (read-only, at the same paths) besides
    Python and FlowNav, with ``python_path`` as its ``PYTHONPATH``; run it with :func:`sandbox_environment`."""
    wanted = {path for path in (*SYSTEM_FILES, *python_paths(), *FLOWNAV_PATHS, *readable) if path.exists()}
    # A path inside another shown one, or inside /usr (shown whole), is shown already.
    shown = sorted(
        path
        for path in wanted
        if not any(_inside(path, other) for other in (*wanted, Path("/usr")) if other != path)
    )
    environment = sandbox_environment(python_path)
    arguments = [
        SANDBOX_PROGRAM,
        "--unshare-user",
        "--unshare-pid",
        "--unshare-net",
        "--unshare-ipc",
        "--unshare-uts",
        "--unshare-cgroup-try",
        "--uid",
        str(NOBODY),
        "--gid",
        str(NOBODY),
        "--die-with-parent",
        "--new-session",  # no controlling terminal: it cannot push keystrokes into the user's
        "--clearenv",
        "--ro-bind",
        "/usr",
        "/usr",
        *_merged_usr_links(),
        "--proc",
        "/proc",
        "--dev",
        "/dev",
        "--size",
        str(SCRATCH_BYTES),
        "--tmpfs",
        SCRATCH,
    ]
    for path in shown:
        arguments += ["--ro-bind", str(path), str(path)]
    for name, value in sorted(environment.items()):
        arguments += ["--setenv", name, value]
    # The sandbox's own root (where bwrap made the folders leading to each bound path) is read-only too.
    return [*arguments, "--remount-ro", "/", "--chdir", SCRATCH, "--", *command]


def _merged_usr_links() -> list[str]:
    """``/bin``, ``/lib``, ``/lib64``, ``/sbin``: links into ``/usr`` where this system has them so, else bound."""
    arguments = []
    for name in ("bin", "lib", "lib64", "lib32", "sbin"):
        path = Path("/") / name
        if path.is_symlink():
            arguments += ["--symlink", os.readlink(path), str(path)]
        elif path.is_dir():
            arguments += ["--ro-bind", str(path), str(path)]
    return arguments


def _inside(path: Path, folder: Path) -> bool:
    return path == folder or folder in path.parents


@functools.cache
def sandbox_problem() -> str | None:
    """Why the sandbox cannot run here (no ``bwrap``, or namespaces it may not create), or None when a probe ran
    in it; probed once per process."""
    if shutil.which(SANDBOX_PROGRAM) is None:
        return f"{SANDBOX_PROGRAM} is not installed"
    probe = sandbox_command([sys.executable, "-c", "import agents.policies.agent_server"], [])
    try:
        result = subprocess.run(
            probe,
            capture_output=True,
            text=True,
            timeout=PROBE_TIMEOUT_S,
            stdin=subprocess.DEVNULL,
            check=False,
        )
    except (OSError, subprocess.SubprocessError) as error:
        return f"{SANDBOX_PROGRAM} did not run: {error}"
    if result.returncode != 0:
        lines = (result.stderr or result.stdout).strip().splitlines()
        return f"{SANDBOX_PROGRAM} failed: {lines[-1] if lines else f'exit status {result.returncode}'}"
    return None


def check_sandbox() -> None:
    """Refuse, in one line, where the sandbox cannot run.

    Raises:
        SandboxUnavailable: why, and how to install it or fly without it.
    """
    problem = sandbox_problem()
    if problem:
        raise SandboxUnavailable(unavailable_message(problem))


def make_undumpable() -> None:
    """Close this process's memory and ``/proc`` entries (``mem``, ``environ``, ``cmdline``, ...) to every process
    of the same user without ``CAP_SYS_PTRACE`` (Linux; elsewhere nothing changes)."""
    try:
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_DUMPABLE, 0, 0, 0, 0)
    except (OSError, AttributeError):
        pass
