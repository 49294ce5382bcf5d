"""Who flies which episode when several runs write one episodes CSV at once.

Just before a task is flown, the process that will fly it takes the CSV's lock and looks at what the CSV
holds and at the claims beside it (``<name>.claims``, one line per episode being flown: host, process id,
time and a digest of the episode's identity). If the episode is in the CSV, or another process that is still
alive claimed it, the task is left to that process; else this process claims it. A claim whose process has
ended (killed, or stopped before writing its row) or that is older than :data:`CLAIM_EXPIRY_S` counts for
nothing, so an interrupted run loses no episode. Appending checks the CSV again under the same lock
(:func:`~agents.analysis.records.append_record`), so even runs that do not claim (Ray workers on other
machines) add each episode once.
"""

from __future__ import annotations

import hashlib
import os
import socket
import time
from dataclasses import dataclass, field
from pathlib import Path

from agents.analysis.csv_file import ReadsPerFile, locked
from agents.analysis.records import flown_episodes

# An episode flies in seconds; a claim this old belongs to a process that stopped without writing its row.
CLAIM_EXPIRY_S = 900.0
CLAIMS_SUFFIX = ".claims"


def claims_path(csv_path: Path) -> Path:
    """The claims file of the episodes CSV at ``csv_path``: ``<name>.claims`` beside it."""
    return csv_path.with_name(csv_path.name + CLAIMS_SUFFIX)


@dataclass(frozen=True)
class Claim:
    """One episode being flown: by which process (``host``, ``pid``), since when (``time``, Unix seconds)."""

    host: str
    pid: int
    time: float

    def is_live(self, now: float) -> bool:
        """Whether the claiming process may still be flying the episode."""
        if now - self.time > CLAIM_EXPIRY_S:
            return False
        if self.host != socket.gethostname():
            return True  # another machine's process cannot be asked; the expiry bounds it
        try:
            os.kill(self.pid, 0)
        except ProcessLookupError:
            return False
        except PermissionError:
            return True  # alive, another user's
        return True


@dataclass
class _ClaimsRead:
    """The claims file as far as it has been read (as for the CSV, only new lines are read each time)."""

    inode: int = -1
    offset: int = 0
    claims: dict[str, Claim] = field(default_factory=dict)

    def update(self, descriptor: int) -> None:
        stat = os.fstat(descriptor)
        if stat.st_ino != self.inode or stat.st_size < self.offset:
            self.inode, self.offset, self.claims = stat.st_ino, 0, {}
        data = os.pread(descriptor, stat.st_size - self.offset, self.offset)
        whole = data[: data.rfind(b"\n") + 1]
        self.offset += len(whole)
        for line in whole.decode("utf-8", "replace").splitlines():
            parts = line.split()
            if len(parts) == 4 and parts[1].isdigit():
                try:
                    self.claims[parts[3]] = Claim(parts[0], int(parts[1]), float(parts[2]))
                except ValueError:
                    continue  # a torn line: its claim is lost, and the episode may fly twice, never count twice


# This process's read of each claims file it claims in.
CLAIMS_READS = ReadsPerFile(_ClaimsRead)


def identity_digest(identity: tuple) -> str:
    """A short, stable name for an episode's identity (:func:`~agents.analysis.records.episode_identity`)."""
    return hashlib.sha256(repr(identity).encode()).hexdigest()[:32]


# What claim_episode found: fly it here; it is in the CSV already; another live run is flying it.
MINE, FLOWN, CLAIMED = "mine", "flown", "claimed"


def claim_episode(csv_path: Path, identity: tuple) -> str:
    """Claim the episode ``identity`` for this process, under the lock of the CSV at ``csv_path``.

    Returns:
        :data:`MINE` when this process should fly it (it is now claimed); :data:`FLOWN` when the CSV holds
        it; :data:`CLAIMED` when another live process claimed it.
    """
    csv_path = Path(csv_path)
    digest = identity_digest(identity)
    with locked(csv_path) as handle:
        if identity in flown_episodes(csv_path, handle):
            return FLOWN
        path = claims_path(csv_path)
        descriptor = os.open(path, os.O_RDWR | os.O_CREAT | os.O_APPEND, 0o644)
        try:
            read = CLAIMS_READS.of(path)
            read.update(descriptor)
            holder = read.claims.get(digest)
            mine = holder is not None and holder.host == socket.gethostname() and holder.pid == os.getpid()
            if holder is not None and not mine and holder.is_live(time.time()):
                return CLAIMED
            os.write(
                descriptor, f"{socket.gethostname()} {os.getpid()} {time.time():.0f} {digest}\n".encode()
            )
        finally:
            os.close(descriptor)
    return MINE


def release_claim(csv_path: Path, identity: tuple) -> None:
    """Give up this process's claim on the episode ``identity`` without writing it (its flight failed), so
    another run flies it at once rather than after :data:`CLAIM_EXPIRY_S`: a claim dated 0 never counts."""
    csv_path = Path(csv_path)
    with locked(csv_path):
        descriptor = os.open(claims_path(csv_path), os.O_RDWR | os.O_CREAT | os.O_APPEND, 0o644)
        try:
            os.write(
                descriptor, f"{socket.gethostname()} {os.getpid()} 0 {identity_digest(identity)}\n".encode()
            )
        finally:
            os.close(descriptor)


def release_claims(csv_path: Path) -> None:
    """Remove the claims file of ``csv_path`` once no live process claims anything in it (the end of a run);
    while another run still flies, its claims stay."""
    csv_path = Path(csv_path)
    path = claims_path(csv_path)
    if not path.exists():
        return
    with locked(csv_path):
        try:
            descriptor = os.open(path, os.O_RDONLY)
        except FileNotFoundError:
            return
        try:
            read = CLAIMS_READS.of(path)
            read.update(descriptor)
            now = time.time()
            others = [
                claim
                for claim in read.claims.values()
                if claim.is_live(now) and (claim.host, claim.pid) != (socket.gethostname(), os.getpid())
            ]
        finally:
            os.close(descriptor)
        if not others:
            path.unlink(missing_ok=True)
