"""The discretization contract (dolfinx_sfvem.discretization, docs/architecture.md), for both methods.

- Both classes implement every abstract member.
- Constraints registered once: constrained rows and columns of the tangent are zeroed with 1 on the
  diagonal (symmetric), the free rows keep K_ff; the residual rows of the constrained unknowns
  become x_c - g_c; the lifting of the residual keeps the Newton step of row elimination.
- Constrained unknowns outside the rank's range are rejected by name.
"""
import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

import dolfinx_sfvem as sf
from dolfinx_sfvem.discretization import Constraints, Discretization
from test_fem import SOLID, direction, medium, state


def discretization(method: str) -> Discretization:
    """[0, 2] x [0, 1]: region 1 left, region 2 (a medium) right, 4 x 4 quads each."""
    mesh = sf.meshes.glue(sf.meshes.quad_rectangle(1.0, 1.0, 4, 4, tag=1),
                          sf.meshes.quad_rectangle(1.0, 1.0, 4, 4, origin=(1.0, 0.0), tag=2))
    materials = {1: SOLID, 2: medium("rotation", None)}
    if method == "vem":
        return sf.SFVEMDiscretization(mesh, materials, verbose=False)
    return sf.LagrangeDiscretization.from_polygon_mesh(mesh, materials, fem_h=0.35, verbose=False)


def test_both_methods_fulfil_the_contract():
    for cls in (sf.SFVEMDiscretization, sf.LagrangeDiscretization):
        assert issubclass(cls, Discretization) and not cls.__abstractmethods__


@pytest.mark.mpi
@pytest.mark.parametrize("method", ["vem", "fem"])
def test_registered_constraints_eliminate_rows_and_columns(method):
    disc = discretization(method)
    x, d = state(disc), direction(disc)
    A, A_c = disc.create_matrix(), disc.create_matrix()
    disc.jacobian(x, A)                                   # nothing registered: the plain tangent
    disc.set_constraints(disc.locate_dofs(lambda X: np.isclose(X[0], 0.0) | np.isclose(X[1], 1.0), component=1))
    disc.jacobian(x, A_c)
    c = disc.constraints.mask[:disc.n_owned_dofs]
    assert MPI.COMM_WORLD.allreduce(int(c.sum()), op=MPI.SUM) > 0
    assert np.array_equal(np.flatnonzero(c), disc.constraints.owned)
    d_free = d.copy()
    d_free.array[c] = 0.0
    y, y_c = disc.create_vector(), disc.create_vector()
    A.mult(d_free, y)                                     # K_ff d_f in the free rows
    A_c.mult(d, y_c)
    assert np.allclose(y_c.array[c], d.array[c], rtol=0, atol=1e-14)
    assert np.allclose(y_c.array[~c], y.array[~c], rtol=1e-13, atol=1e-13 * np.abs(y.array).max())
    assert A_c.isSymmetric(1e-12 * A_c.norm(PETSc.NormType.INFINITY))

    b = disc.create_vector()
    disc.residual(x, b)
    free = b.array[~c].copy()
    g = np.linspace(-1.0, 1.0, disc.constraints.owned.size)
    disc.constraints.set_residual_rows(x, b, g)
    assert np.array_equal(b.array[c], x.array[c] - g)
    assert np.array_equal(b.array[~c], free)


@pytest.mark.mpi
@pytest.mark.parametrize("method", ["vem", "fem"])
def test_lifting_keeps_the_newton_step(method):
    """The step d of the row-eliminated system (K_f d = b_f, d_c = r_c) solves the symmetric one."""
    disc = discretization(method)
    x, d = state(disc), direction(disc)
    disc.set_constraints(disc.locate_dofs(lambda X: np.isclose(X[0], 0.0) | np.isclose(X[1], 1.0)))
    c = disc.constraints.mask[:disc.n_owned_dofs]
    A = disc.create_matrix()
    disc.assemble_tangent(x, A)
    b = disc.create_vector()
    A.mult(d, b)
    b.array[c] = d.array[c]                               # the row-eliminated system's right-hand side
    disc.constraints.eliminate(A, b)
    Ad = disc.create_vector()
    A.mult(d, Ad)
    assert np.abs(d.array[c]).max(initial=0.0) > 0 or not c.any()
    assert np.allclose(Ad.array, b.array, rtol=0, atol=1e-12 * np.abs(b.array).max())


def test_constraints_outside_the_local_unknowns_are_rejected():
    with pytest.raises(ValueError, match=r"constrained unknowns must lie in \[0, 4\)"):
        Constraints(np.array([1, 5]), 4, 4)
