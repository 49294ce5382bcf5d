"""Help pages read as plain text: the docstrings they come from lose their reStructuredText markup, keep their
paragraphs, and say where the commands really write."""

from __future__ import annotations

import pytest

from agents.cli import COMMANDS, build_parser
from agents.cli.bench import SCRATCH_OUT
from agents.cli.help_text import plain_text

BENCH_TARGETS = ("estimator", "env", "recipe", "yield", "isolation")
PAGES = [[], *([name] for name in COMMANDS), *(["bench", target] for target in BENCH_TARGETS)]


def help_page(command: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    with pytest.raises(SystemExit) as exit_info:
        build_parser().parse_args([*command, "--help"])
    assert exit_info.value.code == 0
    return capsys.readouterr().out


@pytest.mark.parametrize(
    ("text", "plain"),
    [
        ("the ``flownav`` command", "the flownav command"),
        ("see :mod:`agents.training.ppo`.", "see agents.training.ppo."),
        (":func:`~agents.evaluation.sweep.run_sweep` flies", "run_sweep flies"),
        (":data:`COMMANDS` and :class:`flownav_env.FlowNavEnv`", "COMMANDS and flownav_env.FlowNavEnv"),
        (":meth:`the sensor <FlowNavEnv.set_sensor>`", "the sensor"),
        ("``flownav\nleaderboard`` and `bench env`", "flownav\nleaderboard and bench env"),
        ("no markup: 95 % of <runs-dir>/x.csv", "no markup: 95 % of <runs-dir>/x.csv"),
    ],
)
def test_plain_text_drops_literals_and_roles(text: str, plain: str) -> None:
    assert plain_text(text) == plain


@pytest.mark.parametrize("command", PAGES, ids=lambda command: " ".join(command) or "flownav")
def test_every_help_page_is_free_of_restructuredtext(
    command: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    page = help_page(command, capsys)
    for markup in ("`", ":mod:", ":func:", ":data:", ":class:", ":meth:"):
        assert markup not in page, f"{markup!r} in flownav {' '.join(command)} --help"


def test_help_pages_keep_the_docstrings_paragraphs(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("COLUMNS", "120")  # argparse wraps to the terminal
    page = help_page(["train"], capsys)
    assert (
        "flownav train: PPO on FlowNav from a YAML config (see agents.training.ppo).\n\nA run writes" in page
    )


def test_bench_help_names_the_folder_it_writes_to_by_default(capsys: pytest.CaptureFixture[str]) -> None:
    page = " ".join(help_page(["bench"], capsys).split())
    assert f"by default {SCRATCH_OUT.as_posix()}, a scratch folder; --out results replaces" in page
    assert "to results/" not in page
    for target in BENCH_TARGETS:
        assert f"(default {SCRATCH_OUT}, a scratch folder" in " ".join(
            help_page(["bench", target], capsys).split()
        )
