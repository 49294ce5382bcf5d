"""``suite.md`` and ``suite.png`` written from what :func:`agents.evaluation.suite.run_suite` flew: the figure,
then the page's values (the ranking per tier, and the sections read from the flights and reports kept beside
the suite), worded by :func:`agents.pages.suite_page.suite_page`."""

from __future__ import annotations

from agents.common.folders import write_text_atomically
from agents.common.seeds import suite_seeds
from agents.common.tables import today
from agents.evaluation.provenance import machine_summary
from agents.evaluation.suite import SuiteFlight
from agents.evaluation.suite_ranking import rank_suite, tier_failures
from agents.pages.suite_page import suite_page, suite_values
from agents.pages.suite_plot import plot_suite
from agents.pages.suite_sections import page_sections
from agents.pages.suite_types import SuiteValues


def write_suite_page(flight: SuiteFlight, command: str) -> list[str]:
    """Write ``suite.png`` (when any row is whole) and ``suite.md`` into the flight's folder; returns the page's
    lines."""
    text = suite_page(suite_page_values(flight, command))
    write_text_atomically(flight.folder / "suite.md", text)
    return text.splitlines()


def suite_page_values(flight: SuiteFlight, command: str) -> SuiteValues:
    """Draw ``suite.png`` from the flight's table and return what ``suite.md`` words."""
    table, rows, runs = flight.table, flight.rows, flight.runs
    whole = {(row["agent"], row["tier"]) for row in table}
    missing = [f"{agent} on {name}" for name in flight.tiers for agent in runs if (agent, name) not in whole]
    if table:
        plot_suite(table, flight.folder / "suite.png")
    seeds = list(suite_seeds(flight.layouts, flight.version))
    failures = {name: tier_failures(rows, runs, name, seeds) for name in flight.tiers}
    rankings = rank_suite(table, failures)
    return suite_values(
        table,
        rankings,
        command=command,
        layouts=suite_seeds(flight.layouts, flight.version),
        machine=machine_summary(),
        missing=missing,
        generated=today(),
        **page_sections(flight.folder, rows, failures, rankings, seeds, flight.version),
        version=flight.version,
    )
