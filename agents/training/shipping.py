"""Shipping a finished run to the policies folder (``results/policies/``): a deliberate step, never a side
effect of training.

The policy, its config, record, evaluations and learning curve go together, all or nothing: each is copied
under a temporary name first, and only when every copy succeeded are they renamed into place, so a shipped
policy never sits beside another run's curve or record. The folder's checksum manifest is updated with the
new policy's hash.
"""

from __future__ import annotations

import shutil
from contextlib import ExitStack
from pathlib import Path

from agents.common.folders import check_writable_folder, replacing_atomically
from agents.common.manifest import record_in_manifest
from agents.training.outputs import RunFiles


def ship_run(files: RunFiles, ship_to: Path) -> list[Path]:
    """Copy the run's policy, config, record, evaluations and learning curve into ``ship_to`` and record the
    policy in its ``MANIFEST.sha256``; returns the shipped paths.

    A run without evaluations (stopped before the first) ships without them, and removes the earlier
    evaluations and curve of the same name from ``ship_to``, which would describe another policy.

    Raises:
        FileNotFoundError: the run has no policy, config or record (train it first).
        ValueError: ``ship_to`` cannot be created or written.
    """
    for required in (files.policy, files.config, files.record):
        if not required.is_file():
            raise FileNotFoundError(
                f"run {files.run_dir} has no {required.name}: train it first (flownav train --config ...)"
            )
    ship_to = Path(ship_to)
    check_writable_folder(ship_to, "--ship-to")
    ship_to.mkdir(parents=True, exist_ok=True)
    copies = {source: ship_to / name for source, name in files.shipped_names().items() if source.is_file()}
    stale = [ship_to / name for source, name in files.shipped_names().items() if not source.is_file()]
    # All copied before any is renamed: a failed copy leaves the shipped files as they were.
    with ExitStack() as renames:
        for source, target in copies.items():
            shutil.copyfile(source, renames.enter_context(replacing_atomically(target)))
    for path in stale:
        path.unlink(missing_ok=True)
    manifest = record_in_manifest(ship_to, [files.policy.name])
    print(f"shipped {files.run_dir} to {ship_to} ({', '.join(t.name for t in copies.values())}); {manifest}")
    return list(copies.values())
