"""The records of a restartable bench driver: ``OUT/NAME.json`` grows case by case, ``OUT/NAME.md`` is made from it.

A driver runs its cases one after the other; every finished case is appended to the JSON at
once, so an interrupted run keeps what it measured and a rerun skips the cases already there.
"""
from __future__ import annotations

import json
import os
import pathlib
import platform
import shutil


def machine() -> str:
    """The machine line of a bench table: cores and processor."""
    return f"{os.cpu_count()} cores, {platform.processor() or platform.machine()}"


class CaseStore:
    """``OUT/NAME.json`` (a list of records) and ``OUT/NAME.md``.

    Parameters
    ----------
    out
        The driver's output directory (made if missing).
    name
        The files' stem.

    Attributes
    ----------
    records : list of dict
        The stored records, oldest first (those of earlier runs, then this run's).
    """

    def __init__(self, out: pathlib.Path, name: str) -> None:
        out.mkdir(parents=True, exist_ok=True)
        self.json, self.md = out / f"{name}.json", out / f"{name}.md"
        self.records: list[dict] = json.loads(self.json.read_text()) if self.json.exists() else []

    def add(self, record: dict) -> None:
        """Append one finished case and write the JSON."""
        self.records.append(record)
        self.json.write_text(json.dumps(self.records, indent=1))

    def write(self, markdown: str, results: pathlib.Path | None = None) -> None:
        """Write the table; with ``results``, copy both files there."""
        self.md.write_text(markdown)
        if results:
            for path in (self.json, self.md):
                shutil.copy(path, results / path.name)
