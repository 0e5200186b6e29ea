"""The results page (demos/results.py) from synthetic summary.json files: no solves.

Checks the tables (Table 2/3 beside the paper, SFVEM vs FEM, rank check), that missing runs are
listed as "not run", and the Table 2 acceptance logic on constructed data. The summary.json
contents come from conftest.py's ``summary_content`` and ``write_summary``.
"""
from __future__ import annotations

import fnmatch

import pytest

import box_self_contact as box
import results_plan
import results_report
import results_runner
from dolfinx_sfvem import paper


def paper_gaps(scale: float = 1.0) -> dict[tuple[float, float, int], float]:
    return {key: scale * value for key, value in results_report.paper_gaps().items()}


def by_criterion(checks: list[results_report.Check]) -> dict[str, str]:
    return {c.criterion: c.result for c in checks}


# --------------------------------------------------------------------------- acceptance logic
def test_acceptance_passes_on_the_papers_values_and_near_them():
    for scale in (1.0, 0.3, 1.2):                                # 1.2: largest gamma = 1e-6 gap 9.9e-4
        checks = results_report.table2_acceptance(paper_gaps(scale))
        assert len(checks) == len(paper.TABLE2) + 3
        assert all(c.result == "PASS" for c in checks), checks
        assert results_report.overall(checks) == "PASS"


def test_acceptance_fails_where_it_should():
    gaps = paper_gaps()
    gaps[(10.0, 1e-4, 2)] *= 20                                   # one gap 20x too large
    checks = by_criterion(results_report.table2_acceptance(gaps))
    assert checks["alpha_r = 10, gamma = 0.0001: g / paper in [0.1, 10]"] == "FAIL"
    assert checks["alpha_r = 1, gamma = 0.0001: g / paper in [0.1, 10]"] == "PASS"
    assert results_report.overall(results_report.table2_acceptance(gaps)) == "FAIL"

    gaps = paper_gaps()
    gaps[(1.0, 1e-5, 1)] = 0.9 * gaps[(1.0, 1e-6, 1)]              # no fall from gamma 1e-5 to 1e-6
    assert by_criterion(results_report.table2_acceptance(gaps))["g falls as gamma falls (every alpha_r, mesh)"] == "FAIL"

    gaps = paper_gaps()
    for g in (1e-4, 1e-5, 1e-6):                                  # alpha_r = 0.1 gaps 100x smaller on mesh 3
        gaps[(0.1, g, 3)] /= 100
    result = results_report.table2_acceptance(gaps)
    assert next(c for c in result if c.criterion.startswith("gamma matters more")).result == "FAIL"

    gaps = paper_gaps()
    gaps[(10.0, 1e-6, 3)] = 1.5e-3
    assert next(c for c in results_report.table2_acceptance(gaps) if c.criterion.startswith("every gamma")).result == "FAIL"


def test_acceptance_is_incomplete_with_missing_runs():
    gaps = {key: value for key, value in paper_gaps().items() if key[2] == 1}     # mesh 1 only
    checks = results_report.table2_acceptance(gaps)
    assert {c.result for c in checks} == {"INCOMPLETE"}
    assert results_report.overall(checks) == "INCOMPLETE"
    gaps[(0.1, 1e-6, 1)] = 5e-3                                   # a failure still shows
    assert results_report.overall(results_report.table2_acceptance(gaps)) == "FAIL"


# --------------------------------------------------------------------------- the page
@pytest.fixture
def page(tmp_path, summary_content, write_summary):
    """results.md written from: all Table 2 runs (1.1 x the paper), C-box mesh 1 both methods and
    its 1-rank check, one FEM run short of the full load; everything else missing."""
    root, docs = tmp_path / "results", tmp_path / "docs"
    for (a, g), values in paper.TABLE2.items():
        for m in (1, 2, 3):
            write_summary(box.run_dir(root / results_plan.TABLE2_DIR, "huhu_lulu", box.BETA, a, g, m),
                          summary_content(extra={"gap": 1.1 * values[m - 1]}))
    write_summary(root / "cbox-mesh1-vem", summary_content(force=2.0, extra={"tip_ux": -0.1}, uy=-0.5))
    write_summary(root / "cbox-mesh1-fem", {**summary_content(force=2.1, extra={"tip_ux": -0.1}, uy=-0.5,
                                                              method="fem"),
                                            "cell_type": "quadrilateral"})
    write_summary(root / "cbox-mesh1-vem-np1",
                  summary_content(force=2.0, extra={"tip_ux": -0.1}, uy=-0.5, ranks=1))
    write_summary(root / "cbox-mesh2-fem",
                  summary_content(converged=False, loads=(0.5,), method="fem", uy=-0.5))
    runs = results_plan.plan(quick=False, ranks=2)
    checks = results_report.write_report(runs, root, docs, quick=False)
    return (docs / "results.md").read_text(), checks, docs


def test_page_tables(page):
    text, checks, docs = page
    for heading in ("## Runs", "### Table 2", "#### Acceptance check", "### Table 3", "### Fig. 4",
                    "### SFVEM vs FEM", "## 1 rank vs N ranks", "## Where we differ from the paper and why"):
        assert heading in text, heading
    assert "| alpha_r | gamma | g mesh 1 | paper mesh 1 | g/paper mesh 1 |" in text
    assert f"| 10 | 0.0001 | {1.1 * paper.TABLE2[(10.0, 1e-4)][0]:.4e} | " \
           f"{paper.TABLE2[(10.0, 1e-4)][0]:.4e} | 1.100 |" in text
    assert "| regularization | g mesh 1 |" in text
    assert results_report.overall(checks) == "PASS" and "Overall: **PASS**" in text
    # SFVEM vs FEM: force 2.0 vs 2.1 at the full load
    assert "| u_y = -0.5, gamma = 1e-5, alpha_r = 1, medium mesh 1 | SFVEM | full load | 2 | 1234 | 1 | 2 |" in text
    assert "| u_y = -0.5, gamma = 1e-5, alpha_r = 1, medium mesh 1 | Q2 FEM | full load |" in text
    assert "+5.00%" in text
    # the rank check compares the 1-rank run with the 2-rank one
    assert "| cbox-mesh1-vem | 2 | 1 | 1 | 2 | 2 | 0.0e+00 |" in text
    assert "(docs/figures)" not in text and (docs / "figures" / "cbox-curves.png").is_file()
    # the hand-kept studies follow the paper's examples, without their editing note
    studies = [line for line in results_report.STUDIES.read_text().splitlines() if line.startswith("## ")]
    assert studies and all(h in text for h in studies) and "<!--" not in text
    assert text.index(studies[0]) < text.index("## 1 rank vs N ranks")


def test_page_lists_missing_and_short_runs(page):
    text, _, _ = page
    assert "| punch-soft-vem | not run |" in text
    assert "| box-table3 | 0 of 9 runs at full load |" in text
    assert "| box-table2 | 27 of 27 runs at full load |" in text
    assert "| cbox-mesh2-fem | stopped at load 0.5 |" in text
    assert "Table 3: not run." in text
    assert "Runs short of the full load: cbox-mesh2-fem (stopped at load 0.5: step 2: load step failed)" in text
    assert "Not analysed: cbox-mesh2-fem." in text
    assert "chose l > 3 in 31 of 31 runs, on at most 10 of 100 polygons" in text


def test_plan_and_selection():
    runs = results_plan.plan(quick=True, ranks=2)
    names = [r.name for r in runs]
    assert len(names) == len(set(names))
    box_vem = next(r for r in runs if r.name == "box-mesh1-vem")
    assert box_vem.out.startswith(results_plan.TABLE2_DIR)            # shared with the Table 2 sweep
    assert ("--h", "0.1") == box_vem.argv[box_vem.argv.index("--h"):box_vem.argv.index("--h") + 2]
    assert [r.name for r in results_plan.select(runs, "cbox-mesh1-*")] == [
        "cbox-mesh1-vem", "cbox-mesh1-fem", "cbox-mesh1-vem-np1", "cbox-mesh1-fem-np1"]
    with pytest.raises(ValueError, match="no run matches nothing"):
        results_plan.select(runs, "nothing")
    serial = results_plan.plan(quick=True, ranks=1)                    # no rank check on 1 rank
    assert all(r.ranks == 1 for r in serial) and not any(r.reference for r in serial)


# --------------------------------------------------------------------------- restart decisions
def test_restart_decisions(tmp_path, summary_content, write_summary):
    """Skip a converged run with the same parameters, resume an interrupted one, keep a failed
    one unless asked, move a run of other parameters aside."""
    run = next(r for r in results_plan.plan(quick=False, ranks=2) if r.name == "cbox-mesh1-vem")
    params = {"method": "vem", "uy": -0.5, "steps": 50, "mesh": 1, "h": 0.05, "gamma": 1e-5}
    done = {**summary_content(uy=-0.5), "parameters": params}
    write_summary(tmp_path / run.out, done)
    assert results_runner.state(run, tmp_path) == "done"
    assert results_runner.prepare(run, tmp_path, retry_failed=False)[:2] == (False, False)
    assert results_runner.remaining(run, tmp_path, retry_failed=False) == 0

    write_summary(tmp_path / run.out, {**done, "converged": False, "message": "running"})
    assert results_runner.state(run, tmp_path) == "other"                    # no checkpoint: start again
    (tmp_path / run.out / "checkpoint.npz").write_bytes(b"")
    assert results_runner.prepare(run, tmp_path, retry_failed=False) == (True, True, "resuming")
    # killed while its HDF5 file was open: the superblock was never written, the XDMF goes aside
    (tmp_path / run.out / "displacement.h5").write_bytes(bytes(64))
    (tmp_path / run.out / "displacement.xdmf").write_text("<Xdmf/>")
    go, resume, note = results_runner.prepare(run, tmp_path, retry_failed=False)
    assert (go, resume) == (True, True) and "unreadable XDMF output moved" in note
    assert not (tmp_path / run.out / "displacement.h5").exists()
    assert len(list((tmp_path / "superseded").glob("cbox-mesh1-vem-xdmf-*/displacement.h5"))) == 1
    (tmp_path / run.out / "displacement.h5").write_bytes(results_runner.HDF5_SIGNATURE + bytes(56))
    assert results_runner.prepare(run, tmp_path, retry_failed=False) == (True, True, "resuming")

    write_summary(tmp_path / run.out, {**done, "converged": False, "message": "step 3: failed"})
    assert results_runner.prepare(run, tmp_path, retry_failed=False)[0] is False
    assert results_runner.prepare(run, tmp_path, retry_failed=True) == (True, False, "running")

    write_summary(tmp_path / run.out, {**done, "parameters": {**params, "steps": 10}})
    go, resume, note = results_runner.prepare(run, tmp_path, retry_failed=False)
    assert (go, resume) == (True, False) and "moved" in note
    assert not (tmp_path / run.out).exists()
    assert len(list((tmp_path / "superseded").glob("cbox-mesh1-vem-*/cbox-mesh1-vem/summary.json"))) == 1


def test_stops_are_sorted_by_their_analysed_cause():
    mesh3 = [f"box-table2/huhu_lulu-beta5/{run}-mesh3" for run in ("alpha_r1-gamma1e-06", "alpha_r10-gamma1e-04")]
    explained, unexplained = results_report.explain_stops(
        ["cbox-mesh1-fem", mesh3[0], "box-table2/huhu_lulu-beta5/alpha_r1-gamma1e-06-mesh2", mesh3[1],
         "punch-rigid-vem"])
    assert unexplained == ["cbox-mesh1-fem", "box-table2/huhu_lulu-beta5/alpha_r1-gamma1e-06-mesh2", "punch-rigid-vem"]
    assert list(explained.values()) == [mesh3] and "box mesh 3" in next(iter(explained))


def test_interrupted_runs_are_not_counted_as_stops(tmp_path, summary_content, write_summary):
    write_summary(tmp_path / "punch-soft-vem-np1",
                  {**summary_content(loads=(0.5,)), "converged": False, "message": "running"})
    write_summary(tmp_path / "cbox-mesh1-vem", summary_content())
    assert results_report._short_runs(tmp_path) == ["Interrupted, `make results` continues them: punch-soft-vem-np1.",
                                             "Every run that finished reached the full load."]
    write_summary(tmp_path / "punch-rigid-vem",
                  {**summary_content(loads=(0.5,)), "converged": False, "message": "step 2: failed"})
    items = results_report._short_runs(tmp_path)
    assert items[1].startswith("Runs short of the full load: punch-rigid-vem (") and items[-1].startswith("Not analysed: ")


def test_analysed_causes_name_existing_examples_and_runs():
    assert set(results_report.ANALYSED_METHOD_DIFFERENCES) <= {e.key for e in results_plan.EXAMPLES}
    names = [r.name for r in results_plan.plan(quick=False, ranks=2)]
    for pattern, _ in results_report.ANALYSED_STOPS:
        first = pattern.split("/")[0]
        assert any(fnmatch.fnmatch(n, first) for n in names), pattern
