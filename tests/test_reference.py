"""The C-box load path on the installed DOLFINx stack against stored DOLFINx 0.5.2 results (issue 14).

A short SFVEM load path of the C-box (paper §5.2): the stored polygon mesh ``data/cbox-h0.1.npz``
(the generator's mesh at h_solid = 0.1, kept so that the gmsh version does not matter), the
left side fixed, u_y = -0.5 at the load point in 10 steps. Every step must be attempted with
the same load factor, converge in the same number of Newton iterations, and give the same
reaction at the load point to 1e-8 relative as ``data/cbox-reference.json``, written on Debian
12's stack (DOLFINx 0.5.2, PETSc 3.18) by ``data/make_reference.py``. A new DOLFINx, PETSc or
FFCx that changes the discrete problem or the solver's path fails here.

After a deliberate change of the discretization or the solver, write the reference again on
Debian 12's stack: ``.venv/bin/python tests/data/make_reference.py``.
"""
from __future__ import annotations

import json
import pathlib

import numpy as np

import dolfinx_sfvem as sf
from dolfinx_sfvem import meshes

DATA = pathlib.Path(__file__).resolve().parent / "data"
MESH = DATA / "cbox-h0.1.npz"
REFERENCE = DATA / "cbox-reference.json"
#: relative tolerance of the reactions (of each step's reaction vector)
RTOL = 1e-8

K, MU = 5 / 3, 5 / 14
UY, STEPS = -0.5, 10
LOAD_POINT = (1.0, 0.5)


def cbox_load_path() -> dict:
    """The load path of the module docstring on the installed stack.

    Returns
    -------
    dict
        ``unknowns``, ``converged`` and per attempted step ``load``, ``converged``,
        ``newton_iterations`` and ``reaction`` ([R_x, R_y] of the ``load`` condition, converged
        steps only).
    """
    problem = sf.ContactProblem(meshes.read_polygons(MESH), {
        meshes.SOLID: sf.Hyperelastic(K=K, mu=MU),
        meshes.MEDIUM: sf.ThirdMedium(mu=MU, gamma=1e-5, alpha_r=1.0, regularization="rotation")},
        verbose=False)
    problem.fix(lambda x: np.isclose(x[0], 0.0))
    problem.prescribe(lambda x: np.hypot(x[0] - LOAD_POINT[0], x[1] - LOAD_POINT[1]) < 1e-10, uy=UY, name="load")
    result = problem.solve(steps=STEPS)
    steps = [{"load": s["load"], "converged": s["converged"], "newton_iterations": s["newton_iterations"],
              **({"reaction": s["reaction"]["load"]} if s["converged"] else {})} for s in result.attempts]
    return {"unknowns": int(problem.disc.num_dofs_global), "converged": result.converged, "steps": steps}


def test_cbox_load_path_matches_dolfinx_052():
    reference = json.loads(REFERENCE.read_text())
    run = cbox_load_path()
    assert run["converged"] and run["unknowns"] == reference["unknowns"]

    def path(r):
        return [(s["load"], s["converged"], s["newton_iterations"]) for s in r["steps"]]

    assert path(run) == path(reference)
    for step, expected in zip(run["steps"], reference["steps"]):
        if expected["converged"]:
            got, want = np.asarray(step["reaction"]), np.asarray(expected["reaction"])
            assert np.linalg.norm(got - want) <= RTOL * np.linalg.norm(want), (step["load"], got, want)
