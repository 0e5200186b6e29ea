"""Markdown output: tables."""
from __future__ import annotations

import typing


def table(header: typing.Sequence[str], rows: typing.Iterable[typing.Sequence[str]]) -> list[str]:
    """A Markdown table: the header line, the rule, one line per row (cells as given)."""
    return ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)] + ["| " + " | ".join(r) + " |"
                                                                             for r in rows]
