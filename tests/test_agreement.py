"""SFVEM and P2 FEM on the same problems (docs/method.md §7 cross-check, issue 4).

- Smooth finite-strain problem without contact: a Hyperelastic unit square whose boundary
  displacement is the trace of a smooth field (shear and compression, J down to ~0.4).
  The discrete energies of both methods converge to the same value; their difference
  falls like ~h^4 (measured rate 4.0 over h = 0.2, 0.1, 0.05). The meshes (polygons, and
  triangles with matched unknowns) are read from ``data/``: gmsh 4.8 made them (written by
  ``data/make_reference.py --meshes``), and other gmsh versions give other meshes.
- C-box (paper §5.2) at u_y = -0.3 at matched unknowns: the reaction at the load point.
- The comparison tool (``python3 demos/compare.py``) on a stand-in demo.
"""
import json
import pathlib
import textwrap

import numpy as np
import pytest

import dolfinx_sfvem as sf
from dolfinx_sfvem import meshes
from dolfinx_sfvem.output.run_summary import RunSummary

import compare

SHEAR, COMPRESSION = 0.2, -0.15
DATA = pathlib.Path(__file__).resolve().parent / "data"
#: sizes h of the stored unit-square meshes
SQUARE_SIZES = (0.2, 0.1, 0.05)


def boundary_field(x, component):
    """Trace of the smooth field (0.2, -0.15) y sin(pi x) on the boundary of the unit square."""
    return (SHEAR if component == 0 else COMPRESSION) * x[1] * np.sin(np.pi * x[0])


def on_boundary(x):
    return np.isclose(x[0], 0.0) | np.isclose(x[0], 1.0) | np.isclose(x[1], 0.0) | np.isclose(x[1], 1.0)


def square_mesh_paths(h: float) -> tuple[pathlib.Path, pathlib.Path]:
    """The stored unit-square meshes of size h: polygons (``meshes.polygon_rectangle``) and their
    triangulation with matched P2 unknowns (``remesh.matched_triangulation``)."""
    return DATA / f"square-h{h}.npz", DATA / f"square-h{h}-fem.npz"


def smooth_energy(method: str, h: float) -> float:
    """Stored energy of the solution on the polygon mesh of size h (FEM: matched unknowns)."""
    polygons, triangles = map(meshes.read_polygons, square_mesh_paths(h))
    fem = {"fem_mesh": triangles} if method == "fem" else {}
    problem = sf.ContactProblem(polygons, {1: sf.Hyperelastic(K=5 / 3, mu=5 / 14)}, method=method, verbose=False,
                                **fem)
    problem.prescribe(on_boundary, ux=lambda x: boundary_field(x, 0), uy=lambda x: boundary_field(x, 1),
                      name="boundary")
    assert problem.solve(steps=2).converged
    info = problem.disc.residual(problem.x, problem.disc.create_vector())
    assert 0.2 < info.min_J < 0.8          # finite strain, no element near inversion
    return info.energy


@pytest.mark.mpi
def test_smooth_hyperelastic_energies_converge_together():
    hs = np.array(SQUARE_SIZES)
    vem = np.array([smooth_energy("vem", h) for h in hs])
    fem = np.array([smooth_energy("fem", h) for h in hs])
    difference = np.abs(vem - fem) / fem
    rate = np.polyfit(np.log(hs), np.log(difference), 1)[0]
    assert np.all(np.diff(difference) < 0), difference
    assert rate >= 2.5, (rate, difference)
    assert difference[-1] < 2e-5, difference
    # each method converges as well (not only towards the other): successive changes shrink
    for energies in (vem, fem):
        assert abs(energies[2] - energies[1]) < 0.3 * abs(energies[1] - energies[0]), energies


# --------------------------------------------------------------------------- C-box
CBOX_K, CBOX_MU = 5 / 3, 5 / 14


def cbox_reaction(method: str, h: float = 0.05, uy: float = -0.3, steps: int = 15) -> tuple[int, float]:
    """(unknowns, R_y at the load point) of the C-box at u_y (gamma 1e-5, alpha_r 1, rotation)."""
    box = sf.meshes.cbox(h_solid=h)
    problem = sf.ContactProblem(box.mesh, {
        sf.meshes.SOLID: sf.Hyperelastic(K=CBOX_K, mu=CBOX_MU),
        sf.meshes.MEDIUM: sf.ThirdMedium(mu=CBOX_MU, gamma=1e-5, alpha_r=1.0, regularization="rotation")},
        method=method, verbose=False)
    problem.fix(lambda x: np.isclose(x[0], 0.0))
    load = np.asarray(box.points["load"])
    problem.prescribe(lambda x: np.hypot(x[0] - load[0], x[1] - load[1]) < 1e-10, uy=uy, name="load")
    result = problem.solve(steps=steps)
    assert result.converged, result.message
    return problem.disc.num_dofs_global, result.steps[-1]["reaction"]["load"][1]


@pytest.mark.slow
def test_cbox_reaction_agrees_at_matched_unknowns():
    """C-box at a moderate load (u_y = -0.2, before contact): at matched unknowns the reactions of
    SFVEM and P2 FEM approach each other under refinement and agree within 2 % once the beams are
    resolved (h = 0.0125, about 4e4 unknowns each).

    Measured when written: 2.28 % apart at h = 0.025 (11002 / 11190 unknowns), 1.46 % at
    h = 0.0125 (39686 / 39842); the SFVEM beams are the stiffer side on coarse meshes. At
    u_y = -0.3 (contact onset) the gap is larger (5.2 % at h = 0.025): the SFVEM regularization
    energy, built from derivatives of the projected gradient, is stiffer than FEM's.
    The default absolute Newton tolerance follows the residual's round-off level (solver.py), so
    the FEM at 4e4 unknowns, whose residual cannot go below about 1.4e-9 (forces of order 1e-4),
    converges without a hand-set tolerance.
    """
    differences = []
    for h in (0.025, 0.0125):
        n_vem, r_vem = cbox_reaction("vem", h=h, uy=-0.2, steps=4)
        n_fem, r_fem = cbox_reaction("fem", h=h, uy=-0.2, steps=4)
        assert abs(n_fem - n_vem) <= 0.05 * n_vem
        differences.append(abs(r_fem - r_vem) / abs(r_fem))
    assert differences[1] < differences[0], differences
    assert differences[1] <= 0.02, differences


# --------------------------------------------------------------------------- comparison tool
FAKE_DEMO = textwrap.dedent("""
    import argparse, json, pathlib
    p = argparse.ArgumentParser()
    p.add_argument("--method"); p.add_argument("--out", type=pathlib.Path); p.add_argument("--uy", type=float)
    a = p.parse_args()
    scale = 1.0 if a.method == "vem" else 1.02
    steps = [{"load": l, "converged": True, "newton_iterations": 3,
              "reaction": {"load": [0.0, a.uy * scale * l]}, "extra": {"gap": 0.3 + a.uy * l}}
             for l in (0.5, 1.0)]
    if a.method == "fem":
        steps.insert(1, {"load": 1.0, "converged": False, "newton_iterations": 30, "reaction": {}, "extra": {}})
    a.out.mkdir(parents=True)
    (a.out / "summary.json").write_text(json.dumps({"method": a.method, "dofs": 100 if a.method == "vem" else 104,
                                                    "converged": True, "wall_time_s": 1.0, "steps": steps}))
""")


def test_compare_tool_runs_both_methods_and_tabulates(tmp_path, capsys):
    demos = tmp_path / "demos"
    demos.mkdir()
    (demos / "fake.py").write_text(FAKE_DEMO)
    out = tmp_path / "cmp"
    assert compare.main(["fake", "--demos", str(demos), "--out", str(out), "--uy", "-0.5"]) == 0
    table = json.loads((out / "comparison.json").read_text())
    rows = {r["quantity"]: r for r in table["rows"]}
    assert rows["unknowns"]["vem"] == 100 and rows["unknowns"]["relative_difference"] == pytest.approx(0.04)
    assert rows["reaction load Ry"]["fem"] == pytest.approx(-0.51)
    assert rows["reaction load Ry"]["relative_difference"] == pytest.approx(-0.02)
    assert rows["gap"]["relative_difference"] == pytest.approx(0.0)
    assert rows["Newton iterations (total)"]["fem"] == 36 and rows["failed step attempts"]["fem"] == 1
    assert table["options"] == ["--uy", "-0.5"]
    assert "| reaction load Ry | -0.5 | -0.51 | -2.000% |" in (out / "comparison.md").read_text()
    assert "reaction load Ry" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        compare.main(["fake", "--demos", str(demos), "--method", "vem"])


def test_compare_tool_sends_fem_options_to_the_fem_run_only():
    common, fem_only = compare.split_fem_options(["--uy", "-0.5", "--fem-cells", "triangles", "-snes_rtol", "1e-9",
                                                  "--fem-jump-penalty=40"])
    assert common == ["--uy", "-0.5", "-snes_rtol", "1e-9"]
    assert fem_only == ["--fem-cells", "triangles", "--fem-jump-penalty=40"]


def test_compare_tool_tabulates_max_displacement(tmp_path):
    """max |u| recorded per step by ContactProblem appears in the table with its relative difference."""
    vem = {"dofs": 10, "converged": True, "wall_time_s": 1.0,
           "steps": [{"load": 1.0, "converged": True, "newton_iterations": 2, "max_displacement": 0.5}]}
    fem = {**vem, "steps": [{**vem["steps"][0], "max_displacement": 0.4}]}
    rows = {r[0]: r for r in compare.compare(RunSummary.from_dict(vem), RunSummary.from_dict(fem))}
    assert rows["max |u|"][1:3] == (0.5, 0.4)
    assert rows["max |u|"][3] == pytest.approx(-0.2)
