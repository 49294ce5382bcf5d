"""Help pages from docstrings: their reStructuredText markup turned into plain text, their paragraphs kept."""

from __future__ import annotations

import argparse
import re
import textwrap

# A role (:mod:`a.b`, :func:`~a.b.c`, :meth:`title <a.b>`), then a literal (``x``, across a line break too),
# then the default role (`x`): a role's backticks must go before the bare-backtick pattern sees them.
_ROLE = re.compile(r":[a-z]+:`(~?)([^`<]*?)\s*(?:<[^`>]*>)?`")
_LITERAL = re.compile(r"``(.+?)``", re.DOTALL)
_INTERPRETED = re.compile(r"`([^`]+)`")


def plain_text(text: str) -> str:
    """``text`` without its reStructuredText markup, for a terminal.

    A literal in double backticks and interpreted text in single ones keep their text. A role (``:mod:``,
    ``:func:``, ``:data:``, ...) keeps its target, cut to the last dotted name after a tilde as Sphinx shows
    it, or its explicit title.

    Args:
        text: A docstring or help string.

    Returns:
        The same text without backticks or role markers.
    """

    def role(match: re.Match[str]) -> str:
        shortened, target = match.groups()
        return target.rsplit(".", 1)[-1] if shortened else target

    return _INTERPRETED.sub(r"\1", _LITERAL.sub(r"\1", _ROLE.sub(role, text)))


class ParagraphHelpFormatter(argparse.HelpFormatter):
    """Refills a description to the terminal's width paragraph by paragraph (blank lines apart), where
    argparse's default runs a docstring's paragraphs into one block; and wraps an option's help between words
    only, where argparse's default cuts a word longer than the line (an agent name: ``bee _robust``)."""

    def _split_lines(self, text: str, width: int) -> list[str]:
        words = " ".join(text.split())
        return textwrap.wrap(words, width, break_long_words=False, break_on_hyphens=False) or [""]

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        paragraphs = re.split(r"\n\s*\n", text.strip())
        return "\n\n".join(
            super(ParagraphHelpFormatter, self)._fill_text(part, width, indent) for part in paragraphs
        )
