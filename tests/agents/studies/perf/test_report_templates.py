"""The speed reports fill templates from computed values: fixed rows give the golden Markdown, claims follow the
data, the templates hold no typed figures, and an installed package ships them.

The golden files in ``data/`` were written by the f-string writers these replaced (same rows, pinned machine
facts), with their three typed figures replaced by the values now derived from the rows.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import re
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from agents.common.jinja_reports import names_in, render, template_fields, template_source, unused_values
from agents.studies.perf import env_speed_report, estimator_speed_report, report_kit
from agents.studies.perf.report_kit import RunFacts

DATA = Path(__file__).with_name("data")
GENERATED = "2026-12-02 14:25 UTC"
HARDWARE = "- Python 3.11.7 on Linux\n- CPU: a test CPU; `nproc` = 2"


def estimator_case(name: str) -> dict[str, Any]:
    return json.loads((DATA / "estimator_report_inputs.json").read_text(encoding="utf-8"))[name]


def env_case(name: str) -> dict[str, Any]:
    return json.loads((DATA / "env_report_inputs.json").read_text(encoding="utf-8"))[name]


def facts(case: dict[str, Any]) -> RunFacts:
    """The run's facts of a case, with the machine pinned."""
    return RunFacts(
        case["command"],
        case["elapsed"],
        GENERATED,
        HARDWARE,
        case.get("cores", 2),
        case.get("software", True),
    )


def estimator_values(case: dict[str, Any]) -> estimator_speed_report.EstimatorPerformanceValues:
    return estimator_speed_report.estimator_report_values(
        case["rows"],
        case["flight"],
        case["repeats"],
        case["defaults"],
        facts(case),
    )


def render_estimator(case: dict[str, Any]) -> str:
    return render(
        report_kit.PACKAGE, "estimator_performance.md.j2", estimator_values(case), every_value_used=True
    )


def render_env(case: dict[str, Any]) -> str:
    values = env_speed_report.env_report_values(case["rows"], case["steps"], case["repeats"], facts(case))
    return render(report_kit.PACKAGE, "env_performance.md.j2", values, every_value_used=True)


def as_numpy(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The rows as the benchmarks make them: numpy scalars, whose comparisons give numpy bools."""
    return [
        {key: np.float64(value) if type(value) is float else value for key, value in row.items()}
        for row in rows
    ]


@pytest.mark.parametrize("name", ["full", "edge"])
def test_estimator_report_reproduces_the_golden_file(name: str) -> None:
    expected = (DATA / f"estimator_performance_{name}.md").read_text(encoding="utf-8")
    case = estimator_case(name)
    assert render_estimator(case) == expected
    case["rows"] = as_numpy(case["rows"])
    assert render_estimator(case) == expected


@pytest.mark.parametrize("name", ["full", "edge"])
def test_env_report_reproduces_the_golden_file(name: str) -> None:
    expected = (DATA / f"env_performance_{name}.md").read_text(encoding="utf-8")
    case = env_case(name)
    assert render_env(case) == expected
    case["rows"] = as_numpy(case["rows"])
    assert render_env(case) == expected


def test_estimator_claims_follow_the_data() -> None:
    case = estimator_case("full")
    default = next(row for row in case["rows"] if row["fast_threshold"] == 20)
    assert "FB on (default) 1.27× → **met** (range 1.21–1.43×, met in 6 of 7 rows)" in render_estimator(case)
    default["ratio_fb_on"] = 1.5
    assert "FB on (default) 1.50× → **missed** (range 1.21–1.50×, met in 5 of 7 rows)" in render_estimator(
        case
    )


def test_env_claims_follow_the_data() -> None:
    case = env_case("full")
    report = render_env(case)
    assert "over the configurations →\n  **missed**.\n" in report
    for row in case["rows"]:
        row["ratio_env_bare"] = 1.1
    case["rows"][0]["real_time_factor_env"] = 25.0
    report = render_env(case)
    assert "env/bare ≤ 1.3: 1.10–1.10 over the configurations →\n  **met**.\n" in report
    assert "default config 25.0× →\n  **met**" in report


def test_the_writers_fill_their_templates_with_this_machine_and_estimator() -> None:
    # The real estimator defaults and machine facts, so a drift between a writer and its template shows here.
    run = RunFacts.of_this_run("flownav bench", time.perf_counter())
    assert run.hardware.startswith("- Python") and run.cores >= 1
    case = estimator_case("full")
    values = estimator_speed_report.estimator_report_values(
        case["rows"],
        case["flight"],
        3,
        estimator_speed_report.estimator_defaults(),
        run,
    )
    report = render(report_kit.PACKAGE, "estimator_performance.md.j2", values, every_value_used=True)
    assert report.startswith("# Estimator performance") and "(method `" in report
    case = env_case("edge")
    values = env_speed_report.env_report_values(
        case["rows"], 3, 1, dataclasses.replace(run, software_renderer=True)
    )
    assert "with software OpenGL" in render(
        report_kit.PACKAGE, "env_performance.md.j2", values, every_value_used=True
    )


# Labels the prose may name: thesis tables and figures, the unit of FPS, an operation count in a formula and
# the condition that makes env workers processes. Every other number is a field's (names such as `cv2` are
# code, not numbers).
ALLOWED_NUMBERS = ("Table 3", "Figs. 39–40", "1000 / total ms", "×2 +", "n_envs > 1")


@pytest.mark.parametrize("path", sorted(report_kit.TEMPLATES.glob("*.j2")), ids=lambda p: p.name)
def test_templates_hold_no_typed_figures(path: Path) -> None:
    prose = re.sub(r"\{\{.*?\}\}|\{%.*?%\}", "", path.read_text(encoding="utf-8"))
    for label in ALLOWED_NUMBERS:
        prose = prose.replace(label, "")
    assert re.findall(r".{0,30}(?<![\w.])\d+(?:\.\d+)?(?!\w).{0,30}", prose) == []


@pytest.mark.skipif(sys.version_info < (3, 11), reason="tomllib")
def test_templates_ship_as_package_data() -> None:
    import tomllib

    pyproject = Path(report_kit.__file__).parents[3] / "pyproject.toml"
    package_data = tomllib.loads(pyproject.read_text(encoding="utf-8"))["tool"]["setuptools"]["package-data"]
    package = Path(report_kit.__file__).parent
    shipped = {path for pattern in package_data["agents.studies.perf"] for path in package.glob(pattern)}
    assert set(report_kit.TEMPLATES.glob("*")) == shipped
    assert shipped >= {report_kit.TEMPLATES / "env_performance.md.j2"}


@dataclasses.dataclass(frozen=True)
class _Drifted(estimator_speed_report.EstimatorPerformanceValues):
    """The report's values with one its template does not name."""

    extra: str


def test_an_edited_template_that_drifts_from_its_values_fails() -> None:
    text = template_source(report_kit.PACKAGE, "estimator_performance.md.j2")
    assert "equal_counts" in names_in(text)
    edited = text.replace("{{ equal_counts }}", "True")
    values = estimator_values(copy.deepcopy(estimator_case("full")))
    assert unused_values(edited, template_fields(values)) == ["equal_counts"]
    drifted = _Drifted(**template_fields(values), extra="1")
    with pytest.raises(
        ValueError, match=r"template 'estimator_performance\.md\.j2': value 'extra' is not used"
    ):
        render(report_kit.PACKAGE, "estimator_performance.md.j2", drifted, every_value_used=True)
