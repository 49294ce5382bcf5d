"""This user's signing key: made on first use, readable only by the user; a key others may read signs nothing."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

from agents.common.signing import key_path, sign, signed_by_this_user, signing_key


@pytest.fixture(autouse=True)
def own_config(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path))


def test_the_key_is_made_once_readable_only_by_this_user() -> None:
    assert signing_key(create=False) is None
    key = signing_key()
    assert key is not None and len(key) == 32 and signing_key() == key
    assert stat.S_IMODE(key_path().stat().st_mode) == 0o600
    assert stat.S_IMODE(key_path().parent.stat().st_mode) == 0o700


def test_a_signature_holds_for_its_payload_only() -> None:
    payload = {"episodes_reflown": 3, "score_sha256": "ab"}
    signature = sign(payload)
    assert signed_by_this_user(payload, signature)
    assert not signed_by_this_user({**payload, "episodes_reflown": 40}, signature)
    assert not signed_by_this_user(payload, None)


def test_a_key_others_may_read_is_refused_in_one_line() -> None:
    signature = sign({"a": 1})
    os.chmod(key_path(), 0o644)
    with pytest.raises(PermissionError, match=r"may be read by others \(mode 644\).*: chmod 600 "):
        sign({"a": 1})
    assert not signed_by_this_user({"a": 1}, signature)
