"""The key this user's verifications are signed with, and the signatures: a record ``flownav verify`` wrote is
told from one written by hand, or by an agent, by an HMAC-SHA256 only this user's key makes.

The key is 32 random bytes, made on first use in ``$XDG_CONFIG_HOME/flownav/verify.key`` (``~/.config`` without
it), readable only by this user; an outside agent's sandbox never shows it. A key that others may read signs
nothing: whoever reads it could forge a record.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import os
import secrets
import stat
from collections.abc import Mapping
from pathlib import Path

KEY_FILE = "verify.key"
KEY_BYTES = 32


def key_path() -> Path:
    """Where this user's signing key lives."""
    config = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    return Path(config) / "flownav" / KEY_FILE


def signing_key(*, create: bool = True) -> bytes | None:
    """This user's signing key, made now where there is none and ``create``; None where there is none.

    Raises:
        PermissionError: the key file may be read by others than this user (one line, with the fix).
    """
    path = key_path()
    if not path.is_file():
        if not create:
            return None
        path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
        try:
            descriptor = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        except FileExistsError:  # another process made it just now: read that one
            return signing_key(create=False)
        with os.fdopen(descriptor, "wb") as handle:
            handle.write(secrets.token_bytes(KEY_BYTES))
    mode = stat.S_IMODE(path.stat().st_mode)
    if mode & 0o077:
        raise PermissionError(
            f"the signing key {path} may be read by others (mode {mode:o}), who could forge verifications with "
            f"it: chmod 600 {path}, or delete it to make a new one"
        )
    return path.read_bytes()


def _message(payload: Mapping[str, object]) -> bytes:
    return json.dumps(payload, sort_keys=True, separators=(",", ":")).encode()


def sign(payload: Mapping[str, object]) -> str:
    """The hex HMAC-SHA256 of ``payload`` (canonical JSON) under this user's key, made if need be."""
    key = signing_key()
    assert key is not None  # made above where there was none
    return hmac.new(key, _message(payload), hashlib.sha256).hexdigest()


def signed_by_this_user(payload: Mapping[str, object], signature: object) -> bool:
    """Whether ``signature`` is this user's key's signature of ``payload`` (False without a key, or with one
    others may read)."""
    try:
        key = signing_key(create=False)
    except PermissionError:
        return False
    if key is None or not isinstance(signature, str):
        return False
    expected = hmac.new(key, _message(payload), hashlib.sha256).hexdigest()
    return hmac.compare_digest(expected, signature)
