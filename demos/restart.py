"""Whether a run of a restartable series is made again: the decision that ``demos/results.py`` and
the box sweeps (``box_self_contact.py --table2 | --table3 | --fig4``) share."""
from __future__ import annotations

import pathlib
import typing

from dolfinx_sfvem.output.run_output import CHECKPOINT
from dolfinx_sfvem.output.run_summary import RunSummary


def run_state(summary: RunSummary | None, wanted: typing.Mapping[str, typing.Any], out: pathlib.Path) -> str:
    """The state of the run in ``out`` whose summary is ``summary``.

    Parameters
    ----------
    summary
        From :func:`~dolfinx_sfvem.output.run_summary.read_summary` (None: no readable summary.json).
    wanted
        The parameters the run is to have; one stored with another value makes it ``other``
        (parameters the summary does not store are not compared).
    out
        The run's output directory (where its checkpoint would be).

    Returns
    -------
    str
        ``missing``; ``other`` (other parameters, or interrupted without a checkpoint: start
        afresh); ``done`` (full load: skip); ``interrupted`` (resume from the checkpoint);
        ``failed`` (stopped short: repeat only on request).
    """
    if summary is None:
        return "missing"
    if any(summary.parameters.get(key, value) != value for key, value in wanted.items()):
        return "other"
    if summary.converged:
        return "done"
    if summary.interrupted:
        return "interrupted" if (out / CHECKPOINT).exists() else "other"
    return "failed"
