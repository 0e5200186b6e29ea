"""Adaptive refinement of the third medium during a load path (dolfinx_sfvem/path_following/adaptivity.py).

References from outside the code under test: J of a homogeneous compression computed by hand,
the polygons an indicator marks recomputed from the mesh, the unknowns of a rebuilt
discretization, and the files written by the run read back through the typed reader. The two
blocks across a medium layer are conftest.py's ``two_blocks``.
"""
import json
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import dolfinx_sfvem as sf
from dolfinx_sfvem.path_following.adaptivity import smallest_J
from dolfinx_sfvem.discretizations.node_keys import sfvem_unknowns
from dolfinx_sfvem.output.run_summary import read_summary
from dolfinx_sfvem.mpi_launcher import job_environment
from process_report import report

DEMOS = pathlib.Path(__file__).resolve().parents[1] / "demos"


def pressed_blocks(two_blocks, mesh: sf.PolygonMesh = None) -> sf.ContactProblem:
    """Two blocks across a medium layer 0.2 thick (or ``mesh``); the upper block pushed down by 0.12."""
    problem = sf.ContactProblem(mesh or two_blocks.mesh(), two_blocks.materials(), verbose=False)
    problem.fix(lambda x: np.isclose(x[1], 0.0))
    problem.prescribe(lambda x: np.isclose(x[1], 2.2), uy=-0.12, name="press")
    return problem


def test_compression_marks_the_medium_below_the_threshold(two_blocks):
    """u = (0, -y/2): J = 1/2 everywhere; only medium polygons can be marked."""
    problem = sf.ContactProblem(two_blocks.mesh(), two_blocks.materials(), verbose=False)
    problem.set_displacement(uy=lambda x: -0.5 * x[1])
    np.testing.assert_allclose(smallest_J(problem), 0.5, rtol=0, atol=1e-12)
    medium = problem.mesh.tags == two_blocks.MEDIUM
    np.testing.assert_array_equal(sf.Compression(J_below=0.6)(problem), medium)
    assert not sf.Compression(J_below=0.4)(problem).any()
    with pytest.raises(ValueError, match="J_below must lie in"):
        sf.Compression(J_below=1.5)


def test_unknowns_of_a_refined_mesh(two_blocks):
    mesh = two_blocks.mesh().refine(lambda x: x[0] < 0.5, tags=[two_blocks.MEDIUM], levels=2).mesh
    assert sfvem_unknowns(mesh) == sf.ContactProblem(mesh, two_blocks.materials(), verbose=False).disc.num_dofs_global


@pytest.mark.mpi
def test_adaptive_path_refines_where_the_indicator_says_within_the_limits(tmp_path, two_blocks):
    """An indicator marking the left half (medium and solid alike): only medium polygons of the left
    half are split, at most twice, one level after each converged step; every step records its
    unknowns and the polygons split after it, in summary.json and load_path.csv."""
    left = lambda p: p.mesh.centroids[:, 0] < 0.5                             # noqa: E731
    adapt = sf.Adaptivity(indicator=left, max_levels=2)
    problem = pressed_blocks(two_blocks)
    coarse = problem.mesh
    out = pathlib.Path(problem.comm.bcast(str(tmp_path), root=0)) / "run"     # one directory for all ranks
    result = problem.solve(steps=4, out=out, adapt=adapt)
    assert result.converged and problem.load == 1.0

    split = [s["refined_polygons"] for s in result.steps]
    assert sum(split) > 0 and split[-1] == 0               # nothing left to split at the end
    assert adapt.level.max() == 2
    assert problem.disc.num_dofs_global == sfvem_unknowns(problem.mesh) > sfvem_unknowns(coarse)
    # the split polygons: children of left-half medium polygons; the rest is the coarse mesh's
    fine = problem.mesh
    unsplit = adapt.level == 0
    assert np.all(fine.tags[~unsplit] == two_blocks.MEDIUM) and np.all(fine.centroids[~unsplit, 0] < 0.5)
    assert np.isclose(fine.areas[fine.tags == two_blocks.MEDIUM].sum(), 0.2)
    assert (~unsplit).sum() == 4 * 4 * 2                     # 2 quads, each into 4 then 16

    problem.comm.barrier()                                                    # rank 0 has written the files
    summary = read_summary(out)
    steps = summary.converged_steps
    assert [s.refined_polygons for s in steps] == split
    dofs = [s.dofs for s in steps]
    assert dofs[0] == sfvem_unknowns(coarse) and dofs[-1] == problem.disc.num_dofs_global
    assert all(b >= a for a, b in zip(dofs, dofs[1:]))
    # a step after a refinement is the re-balancing at the same load, on the new mesh
    for before, after in zip(steps, steps[1:]):
        if before.refined_polygons:
            assert after.load == pytest.approx(before.load) and after.dofs > before.dofs
    if problem.comm.rank == 0:
        header = (out / "load_path.csv").read_text().splitlines()[0].split(",")
        assert {"dofs", "refined_polygons"} <= set(header)


def test_adaptive_path_respects_the_unknowns_limit(two_blocks):
    coarse_dofs = sfvem_unknowns(two_blocks.mesh())
    adapt = sf.Adaptivity(indicator=lambda p: p.mesh.tags == two_blocks.MEDIUM, max_levels=3,
                          max_unknowns=coarse_dofs + 300)
    problem = pressed_blocks(two_blocks)
    result = problem.solve(steps=3, adapt=adapt)
    assert result.converged
    assert coarse_dofs < problem.disc.num_dofs_global <= coarse_dofs + 300
    assert sum(s["refined_polygons"] for s in result.steps) == 4    # one split of the 4 medium quads, then the limit


def test_adaptive_result_matches_the_final_mesh_solved_from_the_start(two_blocks):
    """The path ends in the same equilibrium as the final mesh solved from the start."""
    adapt = sf.Adaptivity(sf.Compression(J_below=0.9), max_levels=1)
    adaptive = pressed_blocks(two_blocks)
    assert adaptive.solve(steps=3, adapt=adapt).converged and adaptive.mesh.n_polygons > two_blocks.mesh().n_polygons
    direct = pressed_blocks(two_blocks, adaptive.mesh)
    assert direct.solve(steps=3).converged
    r, r_direct = (p.reactions()["press"][1] for p in (adaptive, direct))
    assert r == pytest.approx(r_direct, rel=1e-7)


@pytest.mark.parametrize("kwargs, message", [
    ({"max_levels": 0}, "max_levels must be an integer >= 1"),
    ({"max_unknowns": -5}, "max_unknowns must be positive"),
    ({"indicator": 0.5}, "indicator must be a function"),
])
def test_bad_adaptivity_input(kwargs, message):
    with pytest.raises(ValueError, match=message):
        sf.Adaptivity(**kwargs)


def test_indicator_of_the_wrong_shape_and_fem_are_refused(two_blocks):
    problem = pressed_blocks(two_blocks)
    with pytest.raises(ValueError, match="indicator returned shape"):
        problem.solve(steps=2, adapt=sf.Adaptivity(indicator=lambda p: np.ones(3, dtype=bool)))
    fem = sf.ContactProblem(two_blocks.mesh(), two_blocks.materials(), method="fem", verbose=False)
    with pytest.raises(ValueError, match="adaptive refinement needs method='vem'"):
        fem.solve(steps=2, adapt=sf.Adaptivity())


def test_demo_adapt_option_needs_the_vem():
    proc = subprocess.run([sys.executable, str(DEMOS / "cbox.py"), "--adapt", "--method", "fem", "--quiet"],
                          capture_output=True, text=True, timeout=120, env=job_environment())
    assert proc.returncode == 2 and "--adapt needs --method vem" in proc.stderr


def test_study_script_reduced_run(tmp_path):
    """demos/local_refinement.py --quick: two coarse C-box runs, a page with their rows, study.json."""
    page = tmp_path / "study.md"
    proc = subprocess.run([sys.executable, str(DEMOS / "local_refinement.py"), "--quick", "--quiet",
                           "--out", str(tmp_path), "--page", str(page)], capture_output=True, text=True, timeout=300,
                          env=job_environment())
    assert proc.returncode == 0, report(proc)
    runs = json.loads((tmp_path / "study.json").read_text())
    assert [r["label"] for r in runs] == ["uniform h = 0.1", "h = 0.1, adaptive"]
    uniform, adaptive = runs
    assert all(r["converged"] for r in runs) and adaptive["dofs"] > uniform["dofs"]
    assert abs(adaptive["force"] / uniform["force"] - 1) < 0.1                # the same problem, another mesh
    text = page.read_text()
    assert "| SFVEM | h = 0.1, adaptive | yes | " + str(adaptive["dofs"]) in text
    assert "Reference: SFVEM uniform h = 0.1" in text

    # a second call keeps the recorded runs and runs only the missing one
    (tmp_path / "study.json").write_text(json.dumps([uniform]))
    proc = subprocess.run([sys.executable, str(DEMOS / "local_refinement.py"), "--quick", "--quiet",
                           "--out", str(tmp_path), "--page", str(page)], capture_output=True, text=True, timeout=300,
                          env=job_environment())
    assert proc.returncode == 0, report(proc)
    again = json.loads((tmp_path / "study.json").read_text())
    assert again[0] == uniform and again[1]["label"] == "h = 0.1, adaptive" and again[1]["dofs"] == adaptive["dofs"]


def test_demo_displacement_observer_follows_a_refinement(two_blocks):
    """The demos' point observers find their node again on a refined mesh."""
    import _common as common
    problem = pressed_blocks(two_blocks)
    observe = common.displacement_observer(problem, common.at_point((0.5, 1.2)), 1)
    problem.refine(lambda x: x[1] > 0.9)
    problem.set_displacement(uy=lambda x: 0.1 * x[0] * x[1])
    assert observe(problem) == pytest.approx(0.1 * 0.5 * 1.2, rel=1e-12)
