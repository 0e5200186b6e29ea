"""The typed run summary (dolfinx_sfvem/output/run_summary.py) against what ContactProblem.solve writes."""
from __future__ import annotations

import dataclasses
import json

import pytest

from dolfinx_sfvem.output.run_summary import RUNNING, STOPPED_BY_SIGNAL, RunSummary, Step, read_summary


def test_read_summary_reads_what_solve_writes(tmp_path, block):
    """Every entry solve writes has its typed place: the run's fields, the discretization's facts,
    and per step the fields of Step (a new entry in summary.json fails here until it is typed)."""
    result = block.compressed(uy=-0.1 * block.HEIGHT).solve(2, out=tmp_path)
    content = json.loads((tmp_path / "summary.json").read_text())
    summary = read_summary(tmp_path)
    assert read_summary(tmp_path / "summary.json") == summary

    step_fields = {f.name for f in dataclasses.fields(Step)}
    assert all(set(step) <= step_fields for step in content["steps"])
    assert set(summary.discretization) == {"polygons", "projection_order_histogram"}
    assert summary.discretization["polygons"] == 10
    assert (summary.method, summary.dofs, summary.ranks) == ("vem", content["dofs"], content["ranks"])
    assert summary.converged is result.converged is True and summary.message == "" and not summary.interrupted
    assert summary.load_reached == result.load == 1.0
    assert [s.load for s in summary.converged_steps] == [s["load"] for s in result.steps]
    assert summary.final_step.reaction == result.steps[-1]["reaction"]
    assert summary.final_step.force("top") == -result.steps[-1]["reaction"]["top"][1]
    assert summary.final_step.value("max_displacement") == result.steps[-1]["max_displacement"]
    assert [s.negative_pivots for s in summary.converged_steps] == [0, 0]     # a compressed block: stable
    assert summary.newton_iterations == sum(s["newton_iterations"] for s in result.attempts)
    assert summary.parameters["materials"]["1"]["energy"] == "Hyperelastic"


def test_missing_or_unreadable_summary_is_none(tmp_path):
    assert read_summary(tmp_path) is None
    (tmp_path / "summary.json").write_text('{"steps": [')
    assert read_summary(tmp_path) is None
    (tmp_path / "summary.json").write_text('{"steps": [{"converged": true}]}')       # a step without load
    assert read_summary(tmp_path) is None


@pytest.mark.parametrize("message, interrupted", [
    (RUNNING, True), (f"{STOPPED_BY_SIGNAL} 15 at load factor 0.5", True), ("step 3: load step failed", False),
    ("", False)])
def test_interrupted_runs_are_told_from_failed_ones(message, interrupted):
    summary = RunSummary.from_dict({"converged": False, "message": message,
                                    "steps": [{"load": 0.5, "converged": True, "extra": {"gap": 0.1}},
                                              {"load": 1.0, "converged": False, "newton_iterations": 30}]})
    assert summary.interrupted is interrupted
    assert summary.load_reached == 0.5 and summary.final_step.value("gap") == 0.1
    assert summary.final_step.value("max_displacement") is None and summary.final_step.force("top") is None
