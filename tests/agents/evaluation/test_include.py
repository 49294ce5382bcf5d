"""An outside agent's rows beside the published ones: shown by a short name, each file counted once, every bad
file or row refused in one line naming it (exit status 2), and the figure marking the included rows."""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

import pytest

from agents.analysis.records import read_records
from agents.cli import main
from agents.evaluation.included import included_mark
from agents.evaluation.progress import PROGRESS_PREFIX
from agents.evaluation.suite_report import (
    read_included,
    read_score_runs,
    read_suite_csv,
    write_score_runs,
)
from agents.pages.suite_plot import plot_label, plot_suite
from flownav_env.tiers import SUITE_VERSION

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "open_gap_agent.py"
TWO_LAYOUTS = ["--tiers", "clean", "--layouts", "2", "--workers", "1"]


@pytest.fixture(scope="module")
def scored(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Real score.csv files of two layouts (the fewest a ranking compares on): the example agent's (included),
    and straight's and the privileged planner's, scored into one folder (the published table)."""
    folder = tmp_path_factory.mktemp("scored")
    mine, published = folder / "mine", folder / "published"
    assert main(["score", "--agent", f"{EXAMPLE}:make_agent", *TWO_LAYOUTS, "--out", str(mine)]) == 0
    for agent in ("straight", "planner"):
        assert main(["score", "--agent", agent, *TWO_LAYOUTS, "--out", str(published)]) == 0
    return {"mine": mine, "published": published / "score.csv"}


def one_error_line(capsys: pytest.CaptureFixture[str], command: str) -> str:
    err = capsys.readouterr().err.strip()
    lines = [line for line in err.splitlines() if not line.startswith(PROGRESS_PREFIX)]
    assert (
        "Traceback" not in err and len(lines) == 1 and lines[0].startswith(f"flownav {command}: error: ")
    ), err
    return lines[0]


def include(scored: dict[str, Path], out: Path, *files: Path | str) -> int:
    argv = ["leaderboard", "--suite", str(scored["published"]), "--out", str(out)]
    return main([*argv, *(item for path in files for item in ("--include", str(path)))])


def test_an_agent_file_is_shown_by_its_stem_and_callable_and_recorded_in_full(
    scored: dict[str, Path],
) -> None:
    (row,) = read_suite_csv(scored["mine"] / "score.csv")
    assert row["agent"] == "open_gap_agent:make_agent"
    for episode in read_records(scored["mine"] / "suite_episodes.csv"):
        assert episode["agent"] == f"{EXAMPLE}:make_agent"  # the full path, beside the file's hash
        assert "source_sha256" in episode["agent_params"]


def test_name_sets_the_rows_agent_without_flying_again(scored: dict[str, Path]) -> None:
    out = scored["mine"]
    assert (
        main(
            [
                "score",
                "--agent",
                f"{EXAMPLE}:make_agent",
                *TWO_LAYOUTS,
                "--name",
                "gap rule",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    (row,) = read_suite_csv(out / "score.csv")
    # The same agent renamed: its rows under the old name are replaced, not kept beside.
    assert row["agent"] == "gap rule" and len(read_records(out / "suite_episodes.csv")) == 2
    assert main(["score", "--agent", f"{EXAMPLE}:make_agent", *TWO_LAYOUTS, "--out", str(out)]) == 0


@pytest.mark.parametrize(
    ("name", "message"),
    [
        ("bee_ttc", "--name 'bee_ttc' reads as the FlowNav agent 'bee_ttc' (names are compared after NFKC"),
        ("bee_robust ", "--name 'bee_robust ' reads as the FlowNav agent 'bee_robust'"),
        ("bee_robust\u200b", "--name 'bee_robust\\u200b' reads as the FlowNav agent 'bee_robust'"),
        ("Bee_Robust", "--name 'Bee_Robust' reads as the FlowNav agent 'bee_robust'"),
        ("ｂｅｅ_ｔｔｃ", "reads as the FlowNav agent 'bee_ttc'"),  # fullwidth letters: NFKC
        ("ppo_flow@2", "--name 'ppo_flow@2' reads as the FlowNav agent 'ppo_flow'"),
        ("my|agent", "--name 'my|agent': a display name is one line of text without '|' or backticks"),
        (" ", "--name ' ': a display name is one line of text"),
    ],
)
def test_a_bad_name_is_refused_before_flying(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, message: str
) -> None:
    argv = [
        "score",
        "--agent",
        f"{EXAMPLE}:make_agent",
        *TWO_LAYOUTS,
        "--name",
        name,
        "--out",
        str(tmp_path / "o"),
    ]
    assert main(argv) == 2
    assert message in one_error_line(capsys, "score")
    assert not (tmp_path / "o" / "suite_episodes.csv").exists()


def test_a_file_included_twice_counts_once(
    scored: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    score_csv = scored["mine"] / "score.csv"
    monkeypatch.chdir(score_csv.parent)
    assert include(scored, tmp_path / "board", score_csv, "./score.csv") == 0
    text = (tmp_path / "board" / "suite_with_included.md").read_text()
    assert text.startswith(
        f"# FlowNav suite v{SUITE_VERSION} with included agents, ranked as `suite.md` ranks\n"
    )
    assert text.count(str(score_csv)) == 1
    rows, files = read_included([score_csv, Path("score.csv")])
    assert len(rows) == 1 and files == [score_csv]


def test_a_missing_include_file_is_one_line(
    scored: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert include(scored, tmp_path / "board", tmp_path / "nowhere.csv") == 2
    line = one_error_line(capsys, "leaderboard")
    assert f"no suite CSV at {tmp_path / 'nowhere.csv'} (flownav score writes one" in line
    assert "Errno" not in line


def _edited(source: Path, target: Path, edit) -> Path:
    lines = source.read_text().splitlines()
    target.write_text("\n".join([lines[0], *(edit(line) for line in lines[1:])]) + "\n")
    return target


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (
            lambda line: line.rsplit(",", 3)[0],
            "line 2: the row has fewer fields than the header (torn or edited)",
        ),
        (lambda line: line + ",extra", "line 2: the row has more fields than the header"),
        (
            lambda line: line.replace(",clean,", ",cleen,", 1),
            "line 2: tier must be one of clean, hard, noisy, hard_noisy, got 'cleen'",
        ),
    ],
)
def test_a_torn_or_edited_row_names_the_file_and_line(
    scored: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str], edit, message: str
) -> None:
    bad = _edited(scored["mine"] / "score.csv", tmp_path / "score.csv", edit)
    assert include(scored, tmp_path / "board", bad) == 2
    line = one_error_line(capsys, "leaderboard")
    assert line.startswith(f"flownav leaderboard: error: {bad}, ") and message in line


def test_a_rate_that_is_not_a_number_names_its_column(
    scored: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with (scored["mine"] / "score.csv").open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    rows[0]["failure_rate"] = "n/a"
    bad = tmp_path / "score.csv"
    with bad.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    assert include(scored, tmp_path / "board", bad) == 2
    assert f"{bad}, line 2: column failure_rate is 'n/a', not a number" in one_error_line(
        capsys, "leaderboard"
    )


def test_an_include_file_without_rows_is_refused(
    scored: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    empty = tmp_path / "score.csv"
    empty.write_text((scored["mine"] / "score.csv").read_text().splitlines()[0] + "\n")
    assert include(scored, tmp_path / "board", empty) == 2
    assert f"{empty} holds no rows" in one_error_line(capsys, "leaderboard")


def test_the_figure_marks_included_rows_with_their_layouts(scored: dict[str, Path], tmp_path: Path) -> None:
    rows, _ = read_included([scored["mine"] / "score.csv"])
    marked = [{**row, "included": True} for row in rows]
    published = read_suite_csv(scored["published"])
    long_name = "ppo_flow_course_approach_curriculum_slow_oracle"
    assert plot_label(long_name, [{**published[0], "agent": long_name}]) == long_name  # never cut
    assert plot_label("straight", published) == "straight"
    assert plot_label(rows[0]["agent"], marked) == f"{rows[0]['agent']}\n(included, 2 layouts)"
    plot_suite([*published, *marked], tmp_path / "suite.png")
    assert (tmp_path / "suite.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def _rewritten(source: Path, target: Path, change) -> Path:
    """A copy of the score.csv ``source`` at ``target`` whose rows ``change`` edited (a list of dicts)."""
    with source.open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    change(rows)
    with target.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    return target


def _set(**values: str):
    return lambda rows: rows[0].update(values)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (
            _set(agent="bee_ttc"),
            "agent 'bee_ttc' reads as the published agent 'bee_ttc': its rows would pass for that agent's",
        ),
        (_set(agent="Bee_Robust"), "agent 'Bee_Robust' reads as the published agent 'bee_robust'"),
        (_set(agent="bee_robust\u200b"), "reads as the published agent 'bee_robust'"),
        (
            _set(agent="planner"),
            "line 2: planner reads privileged data, but its row is not marked privileged",
        ),
        (_set(timeout_rate="1.5"), "timeout rate 1.5 [0.0, "),
        (_set(timeout_rate="nan"), "timeout rate nan [0.0, "),
        (_set(timeout_rate="-0.1"), "timeout rate -0.1 [0.0, "),
        (_set(out_of_bounds_low="0.5"), "out_of_bounds rate 0 lies outside its interval [0.5, "),
        (
            _set(out_of_bounds_rate="0.5", out_of_bounds_high="1.0"),
            "the rates of collision, out_of_bounds, timeout, success sum to 1.5, not 1",
        ),
        (
            _set(layouts="5000", episodes="5000"),
            "runs 1 and layouts 5000: a suite row has runs >= 1 and layouts from 1",
        ),
        (_set(layouts="0", episodes="0"), "runs 1 and layouts 0: a suite row"),
        (_set(layouts="-3", episodes="-3"), "runs 1 and layouts -3: a suite row"),
        (_set(episodes="7"), "episodes 7 is not runs × layouts (1 × 2)"),
        (
            lambda rows: rows.append(dict(rows[0])),
            "a second row of agent 'open_gap_agent:make_agent' on tier clean",
        ),
        (
            lambda rows: rows[0].update(
                env_kwargs=json.dumps({**json.loads(rows[0]["env_kwargs"]), "obs_source": "oracle"})
            ),
            "asks for obs_source='oracle', privileged data the tier clean sensor does not give",
        ),
    ],
)
def test_an_included_row_that_cannot_be_a_suite_row_is_refused(
    scored: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str], change, message: str
) -> None:
    bad = _rewritten(scored["mine"] / "score.csv", tmp_path / "score.csv", change)
    assert include(scored, tmp_path / "board", bad) == 2
    line = one_error_line(capsys, "leaderboard")
    assert line.startswith(f"flownav leaderboard: error: {bad}") and message in line, line
    assert not (tmp_path / "board").exists()


def test_a_published_privileged_agent_not_marked_privileged_is_refused(
    scored: dict[str, Path], tmp_path: Path
) -> None:
    bad = _rewritten(scored["published"], tmp_path / "suite.csv", _set(agent="planner", privileged="False"))
    with pytest.raises(
        ValueError, match=r"line 2: planner reads privileged data, but its row is not marked privileged$"
    ):
        read_suite_csv(bad)


def test_a_name_that_would_write_markdown_is_escaped_and_included_rows_are_marked(
    scored: dict[str, Path], tmp_path: Path
) -> None:
    name = "evil\n| fake | 0.00 |`"
    renamed = _rewritten(scored["mine"] / "score.csv", tmp_path / "score.csv", _set(agent=name))
    # Its episodes beside it, under the new name, as flownav score --name would leave them.
    shutil.copy(scored["mine"] / "suite_episodes.csv", tmp_path / "suite_episodes.csv")
    write_score_runs(tmp_path, name, read_score_runs(scored["mine"])["open_gap_agent:make_agent"])
    assert include(scored, tmp_path / "board", renamed) == 0
    text = (tmp_path / "board" / "suite_with_included.md").read_text()
    assert "| `evil \\| fake \\| 0.00 \\|'` (included, self-reported) |" in text
    assert not any(line.startswith("| fake") for line in text.splitlines())
    assert f"- `{renamed}`: self-reported" in text


def test_agents_scored_into_one_folder_each_keep_their_rows(scored: dict[str, Path]) -> None:
    rows = read_suite_csv(scored["published"])
    assert sorted(row["agent"] for row in rows) == ["planner", "straight"]


def test_an_included_agent_is_ranked_as_the_suite_ranks_and_the_figure_agrees(
    scored: dict[str, Path], tmp_path: Path
) -> None:
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot

    from agents.evaluation.included import included_suite
    from agents.pages.included_page import included_page
    from agents.pages.suite_plot import _plot_tier

    included = included_suite(scored["published"], [scored["mine"] / "score.csv"])
    text, rows, rankings = (
        included_page(included, "flownav leaderboard --include x"),
        included.table,
        included.rankings,
    )
    ranking = rankings["clean"]
    # The planner is privileged: a reference apart, never ranked nor best.
    assert ranking.left_out == {"planner": "privileged: a reference"}
    assert {ranking.best, *(c.agent for c in ranking.comparisons)} == {
        "straight",
        "open_gap_agent:make_agent",
    }
    table = text.split("## The table", 1)[1]
    ranked, references = table.split("References, privileged and never ranked", 1)
    assert "`open_gap_agent:make_agent` (included, self-reported)" in ranked and "`planner`" in references
    assert "| failure − best [95 % CI] | P(improvement) | Holm p | top group |" in ranked
    (other,) = ranking.comparisons
    line = next(line for line in ranked.splitlines() if f"`{other.agent}`" in line)
    assert f"{other.difference:+.2f}" in line and line.rstrip(" |").endswith(
        "yes" if other.agent in ranking.top_group else "no"
    )
    # The figure: references grey; a ranked agent outside the top group hollow, as the page says.
    figure, axis = pyplot.subplots()
    agents = sorted({row["agent"] for row in rows})
    _plot_tier(axis, "clean", rows, agents, ("straight",))
    markers = [container.lines[0] for container in axis.containers]  # each errorbar's data point
    faces = {agents[int(marker.get_ydata()[0])]: marker.get_markerfacecolor() for marker in markers}
    assert faces["open_gap_agent:make_agent"] == "white" and faces["straight"] != "white"
    assert faces["planner"] != "white"
    pyplot.close(figure)


def test_the_include_command_writes_the_ranked_page_its_table_and_figure(
    scored: dict[str, Path], tmp_path: Path
) -> None:
    assert include(scored, tmp_path / "board", scored["mine"] / "score.csv") == 0
    board = tmp_path / "board"
    assert "Holm p" in (board / "suite_with_included.md").read_text()
    assert {row["agent"] for row in read_suite_csv(board / "suite_with_included.csv")} == {
        "straight",
        "planner",
        "open_gap_agent:make_agent",
    }
    assert (board / "suite_with_included.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_rows_on_one_layout_cannot_be_ranked_and_say_so(
    scored: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    one = _edited(
        scored["mine"] / "score.csv",
        tmp_path / "score.csv",
        lambda line: line.replace(",1,2,2,", ",1,1,1,", 1),
    )
    assert include(scored, tmp_path / "board", one) == 2
    assert "an included row rests on 1 layout; a ranking compares agents on at least 2" in one_error_line(
        capsys, "leaderboard"
    )


def test_one_tier_figure_is_as_wide_as_its_longest_name(scored: dict[str, Path], tmp_path: Path) -> None:
    """The demo draws one tier: the figure widens for long agent names and wraps its title, so matplotlib lays it
    out without clipping (a clipped layout warns)."""
    import warnings

    from PIL import Image

    published = read_suite_csv(scored["published"])
    long_name = "ppo_flow_course_approach_curriculum_slow_oracle"
    rows = [*published, {**published[0], "agent": long_name}]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        plot_suite(rows, tmp_path / "long.png")
        plot_suite(published, tmp_path / "short.png")
        plot_suite(rows[-1:], tmp_path / "one_row.png")  # a single (agent, tier) flight's page
    with Image.open(tmp_path / "long.png") as long_image, Image.open(tmp_path / "short.png") as short_image:
        assert long_image.width > short_image.width


def test_include_verify_re_flies_in_the_same_command_and_marks_only_then(
    scored: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    copy = Path(shutil.copytree(scored["mine"], tmp_path / "mine"))
    assert include(scored, tmp_path / "plain", copy / "score.csv") == 0
    assert "self-reported" in (tmp_path / "plain" / "suite_with_included.md").read_text()
    argv = ["leaderboard", "--suite", str(scored["published"]), "--out", str(tmp_path / "checked")]
    assert main([*argv, "--include", str(copy / "score.csv"), "--verify"]) == 0
    out = capsys.readouterr().out
    assert f"{copy / 'score.csv'}: verified 2/2: each ends as the file says" in out
    page = (tmp_path / "checked" / "suite_with_included.md").read_text()
    assert "verified (re-flown in this command: 2 episodes)" in page


def test_rows_flown_without_the_sandbox_say_so(tmp_path: Path) -> None:
    out = tmp_path / "bare"
    argv = ["score", "--agent", f"{EXAMPLE}:make_agent", "--tiers", "clean", "--layouts", "1"]
    assert main([*argv, "--workers", "1", "--out", str(out), "--no-sandbox"]) == 0
    (episode,) = read_records(out / "suite_episodes.csv")
    assert episode["isolation"] == "process, no sandbox" and episode["cpu"]
    assert included_mark(out / "score.csv", {}) == "self-reported; flown without the sandbox (--no-sandbox)"


def test_sandboxed_rows_say_so(scored: dict[str, Path]) -> None:
    episodes = read_records(scored["mine"] / "suite_episodes.csv")
    assert {episode["isolation"] for episode in episodes} == {"sandbox"}
    assert included_mark(scored["mine"] / "score.csv", {}) == "self-reported"


def test_the_included_page_holds_the_published_pages_sections(
    scored: dict[str, Path], tmp_path: Path
) -> None:
    assert include(scored, tmp_path / "board", scored["mine"] / "score.csv") == 0
    text = (tmp_path / "board" / "suite_with_included.md").read_text()
    for heading in ("## What each tier allows", "## From the map to flow", "## Learning against the rules"):
        assert heading in text


def test_the_figure_lists_agents_as_the_tables_do() -> None:
    from agents.pages.suite_plot import figure_order

    def row(agent: str, failure: float, runs: int = 1, privileged: bool = False) -> dict:
        return {"agent": agent, "failure_rate": failure, "runs": runs, "privileged": privileged}

    rows = [
        row("planner", 0.0, privileged=True),
        row("ppo_oracle", 0.05, runs=5, privileged=True),
        row("ppo_flow_course_approach_curriculum_slow", 0.1, runs=5),  # learned, too few seeds: provisional
        row("vfh", 0.4),
        row("bee", 0.2),
        row("ppo_flow", 0.3, runs=10),
        row("outside.module:make_agent", 0.25),  # an outside agent's name is ranked, never refused
    ]
    assert figure_order(rows) == [
        "bee",
        "outside.module:make_agent",
        "ppo_flow",
        "vfh",
        "ppo_flow_course_approach_curriculum_slow",
        "planner",
        "ppo_oracle",
    ]
