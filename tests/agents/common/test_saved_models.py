"""Reading a model zip names a file cut short as cut short, and SB3's own (unpickling) load fails in one line."""

from __future__ import annotations

import re
import zipfile
from pathlib import Path

import pytest
from pickle_payloads import tiny_model

from agents.common.saved_models import describe_error, load_unpickled, read_saved_model


@pytest.fixture(scope="module")
def ppo_zip(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tiny_model("ppo", tmp_path_factory.mktemp("ppo"))


def cut_points(path: Path) -> list[int]:
    """Sizes to cut ``path`` to: every tenth, and the end of each entry (where a stored torch zip inside ends,
    so zipfile finds that zip's directory at the very end of the file)."""
    size = path.stat().st_size
    with zipfile.ZipFile(path) as archive:
        starts = sorted(entry.header_offset for entry in archive.infolist())
    return sorted({size * tenth // 10 for tenth in range(1, 10)} | set(starts[1:]))


def test_a_zip_cut_anywhere_is_called_cut_short(ppo_zip: Path, tmp_path: Path) -> None:
    content = ppo_zip.read_bytes()
    for size in cut_points(ppo_zip):
        cut = tmp_path / f"cut_{size}.zip"
        cut.write_bytes(content[:size])
        with pytest.raises(ValueError) as raised:
            read_saved_model(cut)
        message = str(raised.value)
        assert message.startswith(f"{cut} is ") and "cut short" in message and "\n" not in message, message
        assert "lacks" not in message


def test_a_whole_zip_without_the_model_entries_is_not_a_model(tmp_path: Path) -> None:
    other = tmp_path / "other.zip"
    with zipfile.ZipFile(other, "w") as archive:
        archive.writestr("notes.txt", "not a model")
    with pytest.raises(
        ValueError, match=rf"^{re.escape(str(other))} is not a stable-baselines3 model: it lacks data"
    ):
        read_saved_model(other)


def test_an_unpickling_load_that_raises_is_one_line_naming_the_file(ppo_zip: Path) -> None:
    from stable_baselines3 import SAC

    # SAC's load on a PPO zip fails inside SB3; the caller gets one line with what SB3 said.
    with pytest.raises(
        ValueError, match=rf"^{re.escape(str(ppo_zip))} could not be loaded as a sac model"
    ) as raised:
        load_unpickled(SAC, ppo_zip, "sac")
    assert "\n" not in str(raised.value)


def test_an_error_reads_as_one_line() -> None:
    assert describe_error(TypeError("bad\n  keyword\targuments ")) == "TypeError: bad keyword arguments"
    assert describe_error(KeyError()) == "KeyError"
