"""The checksum manifest of a policies folder (``results/policies/MANIFEST.sha256``, ``sha256sum`` format).

Loading a policy reads files that someone else may have made. The manifest lists the policies shipped in a
folder with their SHA-256, so that a loader can tell a shipped policy from one that was swapped, edited or
dropped in (``sha256sum -c MANIFEST.sha256`` checks the folder by hand).
"""

from __future__ import annotations

import fcntl
import hashlib
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

MANIFEST_NAME = "MANIFEST.sha256"


def file_sha256(path: Path) -> str:
    """The file's SHA-256 as lowercase hex."""
    digest = hashlib.sha256()
    with Path(path).open("rb") as file:
        for block in iter(lambda: file.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def read_manifest(manifest: Path) -> dict[str, str]:
    """File name → SHA-256 from a ``sha256sum``-format manifest; empty when the file does not exist.

    Raises:
        ValueError: a line that is not ``<64 hex digits>  <file name>``; the message names the file and line.
    """
    if not manifest.is_file():
        return {}
    entries = {}
    for number, line in enumerate(manifest.read_text().splitlines(), start=1):
        if not line.strip():
            continue
        digest, _, name = line.partition("  ")
        name = name.lstrip("*")
        if len(digest) != 64 or not name or any(c not in "0123456789abcdef" for c in digest):
            raise ValueError(f"{manifest}: line {number} is not '<sha256>  <file name>': {line!r}")
        entries[name] = digest
    return entries


def write_manifest(manifest: Path, entries: dict[str, str]) -> None:
    """Write ``entries`` (file name → SHA-256) sorted by name, atomically (temp file, then rename)."""
    text = "".join(f"{digest}  {name}\n" for name, digest in sorted(entries.items()))
    temporary = manifest.with_name(f".{manifest.name}.tmp")
    temporary.write_text(text)
    os.replace(temporary, manifest)


@contextmanager
def manifest_lock(manifest: Path) -> Iterator[None]:
    """Holds an exclusive ``flock`` on the folder of ``manifest`` for the block, so that two processes shipping
    seeds into one folder at once each add their entry instead of one overwriting the other's. The folder
    itself is locked, so no lock file is left among the shipped ones."""
    descriptor = os.open(manifest.parent, os.O_RDONLY)
    try:
        fcntl.flock(descriptor, fcntl.LOCK_EX)
        yield
    finally:
        os.close(descriptor)  # closing the descriptor releases its lock


def record_in_manifest(directory: Path, file_names: list[str]) -> Path:
    """Add or update ``file_names`` (files in ``directory``) in its manifest, read and rewritten under
    :func:`manifest_lock`; returns the manifest's path."""
    manifest = Path(directory) / MANIFEST_NAME
    with manifest_lock(manifest):
        entries = read_manifest(manifest)
        for name in file_names:
            entries[name] = file_sha256(Path(directory) / name)
        write_manifest(manifest, entries)
    return manifest


def manifest_problem(policy: Path) -> str | None:
    """Why ``policy`` is not a verified shipped policy (not listed in the manifest of its folder, or its hash
    differs), or None when it is listed with a matching hash."""
    policy = Path(policy)
    manifest = policy.parent / MANIFEST_NAME
    try:
        entries = read_manifest(manifest)
    except ValueError as error:
        return f"its folder's manifest is unreadable ({error})"
    if policy.name not in entries:
        where = f"listed in {manifest}" if manifest.is_file() else f"beside a {MANIFEST_NAME} ({manifest})"
        return f"{policy} is not {where}: it is not a shipped policy, so nothing vouches for its contents"
    if file_sha256(policy) != entries[policy.name]:
        return f"{policy} does not match its SHA-256 in {manifest}: the file changed since it was shipped"
    return None
