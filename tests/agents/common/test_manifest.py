"""The checksum manifest of a policies folder (agents/common/manifest.py)."""

from __future__ import annotations

import multiprocessing
from pathlib import Path

import pytest

from agents.common.manifest import (
    MANIFEST_NAME,
    file_sha256,
    manifest_problem,
    read_manifest,
    record_in_manifest,
)


def _ship_many(directory: str, prefix: str, count: int) -> None:
    for k in range(count):
        name = f"{prefix}_{k}.zip"
        (Path(directory) / name).write_bytes(f"{prefix}{k}".encode())
        record_in_manifest(Path(directory), [name])


def test_processes_shipping_into_one_folder_at_once_lose_no_entry(tmp_path: Path) -> None:
    context = multiprocessing.get_context("fork")
    writers = [context.Process(target=_ship_many, args=(str(tmp_path), f"seed{w}", 40)) for w in range(3)]
    for writer in writers:
        writer.start()
    for writer in writers:
        writer.join(timeout=60)
    assert all(writer.exitcode == 0 for writer in writers)
    entries = read_manifest(tmp_path / MANIFEST_NAME)
    assert sorted(entries) == sorted(path.name for path in tmp_path.glob("*.zip"))
    assert len(entries) == 120
    assert all(entries[name] == file_sha256(tmp_path / name) for name in entries)


def test_a_policy_changed_after_shipping_is_named_as_changed(tmp_path: Path) -> None:
    policy = tmp_path / "seed_0.zip"
    policy.write_bytes(b"weights")
    record_in_manifest(tmp_path, [policy.name])
    assert manifest_problem(policy) is None
    policy.write_bytes(b"other weights")
    assert "does not match its SHA-256" in str(manifest_problem(policy))


def test_a_malformed_manifest_line_is_named_with_its_file_and_line(tmp_path: Path) -> None:
    (tmp_path / MANIFEST_NAME).write_text("not-a-digest  seed_0.zip\n")
    with pytest.raises(ValueError, match=r"MANIFEST.sha256: line 1 is not '<sha256>  <file name>'"):
        read_manifest(tmp_path / MANIFEST_NAME)
