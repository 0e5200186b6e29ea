"""The mesh refinement page (demos/refinement.py) from synthetic summary.json files: no solves.

Checks the verdict "as it should" (never converged with overlapping solids; a stop only where one
is the honest outcome), the smallest gap over the load path, the force change against the next
coarser mesh, and that the planned runs are the demos' own options. The summary.json contents
come from conftest.py's ``summary_content`` and ``write_summary``."""
from __future__ import annotations

import pytest
import refinement
import results_runner

from dolfinx_sfvem.output.run_summary import RunSummary


def with_gaps(content: dict, gaps, overlap: float = 0.0) -> dict:
    for step, value in zip(content["steps"], gaps):
        step["gap"] = {"value": value, "x": [0.8, -0.06], "X": [1.0, 0.4], "region": 1, "partner_region": 1,
                       "body": 0, "partner_body": 0, "overlap": overlap if value < 0 else 0.0}
    return content


SIZE = refinement.Size("h = 1", ("--h", "1"), 1.0, "s")
THIN = refinement.Size("thin", ("--h", "1"), 1.0, "t", may_stop=True)


@pytest.mark.parametrize("size, converged, gaps, overlap, verdict", [
    (SIZE, True, [0.1, 0.01], 0.0, True),                                        # full load, apart
    (SIZE, True, [0.1, -0.05], 50.0, False),                                     # converged, overlapping
    (SIZE, False, [0.1, 0.01], 0.0, False),                                      # stopped, stop not expected
    (THIN, False, [0.1, 0.001], 0.0, True),                                      # the honest stop
    (THIN, True, [0.1, -0.05], 50.0, False),
    (SIZE, None, None, None, None),                                              # not run
])
def test_verdict(size, converged, gaps, overlap, verdict, summary_content):
    content = gaps and with_gaps(summary_content(converged=converged), gaps, overlap=overlap)
    assert refinement.expected(size, content and RunSummary.from_dict(content)) is verdict


def test_rows_give_the_smallest_gap_and_the_change_against_the_coarser_mesh(summary_content):
    study = refinement.STUDIES[0]
    coarse = refinement.Size("coarse", ("--h", "0.1"), 1.0, "s")
    fine = refinement.Size("fine", ("--h", "0.05"), 1.0, "s")
    rows = refinement.rows(study, [(size, "vem",
                                    RunSummary.from_dict(with_gaps(summary_content(force=force), gaps)))
                                   for size, force, gaps in ((coarse, 2.0, [0.2, 0.05]), (fine, 1.9, [0.02, 0.04]))])
    assert rows[0][4] == "+5.000e-02" and rows[1][4] == "+2.000e-02"          # smallest over the path
    assert rows[1][6] == "+4.000e-02"                                         # final gap
    assert rows[0][8] == "—" and rows[1][8] == "-5.00%"
    assert rows[0][-1] == rows[1][-1] == "yes"


def test_plan_uses_the_demos_options():
    entries = refinement.plan(quick=False, ranks=2)
    names = [run.name for *_, run in entries]
    assert len(names) == len(set(names)) == 2 * sum(len(s.sizes) for s in refinement.STUDIES)
    for _, _, _, run in entries:
        results_runner.expected_parameters(run)           # the demo's own parser accepts the options
    assert all(len(s.sizes) >= 2 for s in refinement.STUDIES)
    assert len(refinement.plan(quick=True, ranks=2)) == 2 * refinement.QUICK_SIZES


def test_report_lists_missing_runs_as_not_run(tmp_path, summary_content, write_summary):
    entries = refinement.plan(quick=True, ranks=2)
    study, size, method, run = entries[0]
    write_summary(tmp_path / run.out, with_gaps(summary_content(), [0.1, 0.01]))
    lines, fine = refinement.report(entries, tmp_path, tmp_path, 2)
    page = (tmp_path / "refinement.md").read_text()
    assert fine and "not run" in page and "+1.000e-02" in page and study.title in page
