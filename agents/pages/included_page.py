"""``suite_with_included.md``: the published suite with included agents ranked among its agents
(:func:`agents.evaluation.included.included_suite`), worded by ``suite.md``'s template with the published page's
sections, the included agents among the failures they are read from."""

from __future__ import annotations

from agents.common.seeds import suite_seeds
from agents.common.tables import markdown_cell, today
from agents.evaluation.included import IncludedSuite
from agents.pages.suite_page import suite_page, suite_values
from agents.pages.suite_sections import page_sections


def included_page(included: IncludedSuite, command: str) -> str:
    """The page's text: every row counted again on the first ``included.layouts`` layouts, each included file
    named with its mark, and the rows that could not be counted again."""
    seeds = list(suite_seeds(included.layouts, included.version))
    values = suite_values(
        included.table,
        included.rankings,
        command=command,
        layouts=suite_seeds(included.layouts, included.version),
        machine="",
        missing=[],
        not_counted=[(markdown_cell(agent), name) for agent, name in included.not_counted],
        generated=today(),
        included_files=[(markdown_cell(path), included.marks[path]) for path in included.files],
        figure="suite_with_included.png",
        **page_sections(
            included.folder,
            included.published_episodes,
            included.failures,
            included.rankings,
            seeds,
            included.version,
        ),
        version=included.version,
    )
    return suite_page(values)
