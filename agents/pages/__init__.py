"""Turns typed values into pages: every Jinja2 template of the reports (``templates/``), the wording filters
(:mod:`.wording`), and the functions that render and write the pages over evaluation's values (the suite, the
sweep, the leaderboard, the suite's checks). Evaluation scores and returns values; nothing below this layer
writes Markdown. The studies above it render their pages through it; the registry of every page is
:mod:`agents.reports`'."""
