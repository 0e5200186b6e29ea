"""The benchmark problems: mesh, materials, boundary conditions, deformed state.

Two geometries of the paper, each with the parameters of its demo (``demos/cbox.py``,
``demos/box_self_contact.py``) and a short, moderate load path that both methods solve
at every size of the benchmark (before contact):

- ``cbox``: C-box (paper §5.2), clamped left side, u_y prescribed at the top right point;
- ``box``: box self-contact (paper §5.1, medium mesh 1), u_y prescribed at the middle of the top.

Mesh sizes and load paths: ``geometries.py``.

Assembly is timed at one deformed state, the same for every size, method and number of
ranks: the smooth field of :func:`set_deformed_state` (nonzero F - I and ∇F everywhere, J
near 1; the smallest J is recorded), so the timing does not depend on a solve.
"""
from __future__ import annotations

import typing

import numpy as np

import dolfinx_sfvem as sf
from geometries import GEOMETRIES


def mesh(geometry: str, h: float) -> sf.meshes.Benchmark:
    """The polygon mesh of ``geometry`` at solid mesh size ``h`` (medium quads of size h)."""
    if geometry == "cbox":
        return sf.meshes.cbox(h_solid=h, medium_refinement=1)
    return sf.meshes.box(mesh=1, h_solid=h)


def materials(geometry: str) -> dict[int, sf.Energy]:
    """Region energies of the geometry's demo (defaults of its command line)."""
    if geometry == "cbox":
        K, mu = 5 / 3, 5 / 14
        medium = sf.ThirdMedium(mu=mu, gamma=1e-5, alpha_r=1.0, regularization="rotation")
    else:
        K, mu = 20.0, 10.0
        medium = sf.ThirdMedium(mu=mu, gamma=1e-6, alpha_r=0.1, regularization="huhu_lulu", beta=5.0)
    return {sf.meshes.SOLID: sf.Hyperelastic(K=K, mu=mu), sf.meshes.MEDIUM: medium}


def _at(xy: typing.Sequence[float], tol: float = 1e-10) -> typing.Callable[[np.ndarray], np.ndarray]:
    return lambda x: np.hypot(x[0] - xy[0], x[1] - xy[1]) <= tol


def add_boundary_conditions(problem: sf.ContactProblem, geometry: str, bench: sf.meshes.Benchmark) -> None:
    """The supports and the prescribed u_y of the geometry's demo."""
    spec = GEOMETRIES[geometry]
    if geometry == "cbox":
        problem.fix(lambda x: np.isclose(x[0], 0.0))
    else:
        problem.fix(_at(bench.points["fixed"]))
        problem.fix(_at(bench.points["roller"]), components=(1,), name="roller")
    problem.prescribe(_at(bench.points["load"]), uy=spec.uy, name="load")


def set_deformed_state(problem: sf.ContactProblem) -> None:
    """The representative deformed state of the assembly timings (ghosts updated).

    u_x = 0.02 sin(π x) cos(π y), u_y = -0.05 x²: bending-like, with nonzero F - I and ∇F
    in every polygon of both geometries.
    """
    from petsc4py import PETSc
    problem.set_displacement(ux=lambda x: 0.02 * np.sin(np.pi * x[0]) * np.cos(np.pi * x[1]),
                             uy=lambda x: -0.05 * x[0] ** 2)
    problem.x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
