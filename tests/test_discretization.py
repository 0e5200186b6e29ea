"""The discretization contract (dolfinx_sfvem.discretizations.discretization, docs/architecture.md), for both methods.

- Both classes implement every abstract member.
- Constraints registered once: constrained rows and columns of the tangent are identity rows and
  columns, the free block unchanged; the residual rows of the constrained unknowns become
  x_c - g_c, and the lifting makes the symmetric system give the step of the row elimination.
- Constrained unknowns outside the rank's range are rejected by name.

The materials, the state and the direction are conftest.py's fixtures (test_fem uses them too).
"""
import numpy as np
import pytest
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem.discretizations.discretization import Constraints, Discretization


def discretization(method: str, materials: dict) -> Discretization:
    """[0, 2] x [0, 1]: region 1 left, region 2 (a medium) right, 4 x 4 quads each."""
    mesh = sf.meshes.glue(sf.meshes.quad_rectangle(1.0, 1.0, 4, 4, tag=1),
                          sf.meshes.quad_rectangle(1.0, 1.0, 4, 4, origin=(1.0, 0.0), tag=2))
    if method == "vem":
        return sf.SFVEMDiscretization(mesh, materials, verbose=False)
    return sf.LagrangeDiscretization.from_polygon_mesh(mesh, materials, fem_h=0.35, verbose=False)


def test_both_methods_fulfil_the_contract():
    for cls in (sf.SFVEMDiscretization, sf.LagrangeDiscretization):
        assert issubclass(cls, Discretization) and not cls.__abstractmethods__


@pytest.mark.mpi
@pytest.mark.parametrize("method", ["vem", "fem"])
def test_registered_constraints_eliminate_rows_and_columns(method, two_region_materials, state_of, direction_of):
    disc = discretization(method, two_region_materials())
    x, d = state_of(disc), direction_of(disc)
    A, A_c = disc.create_matrix(), disc.create_matrix()
    disc.jacobian(x, A)                                   # nothing registered: the plain tangent
    disc.set_constraints(disc.locate_dofs(lambda X: np.isclose(X[0], 0.0) | np.isclose(X[1], 1.0), component=1))
    disc.jacobian(x, A_c)
    c = disc.constraints.mask[:disc.n_owned_dofs]
    assert MPI.COMM_WORLD.allreduce(int(c.sum()), op=MPI.SUM) > 0
    assert np.array_equal(np.flatnonzero(c), disc.constraints.owned)
    d_f, d_c = d.copy(), d.copy()                         # d split into its free and constrained parts
    d_f.array[c] = 0.0
    d_c.array[~c] = 0.0
    y_f, y_c, y_cc = disc.create_vector(), disc.create_vector(), disc.create_vector()
    A.mult(d_f, y_f)
    A.mult(d_c, y_c)                                      # K_fc d_c on the free rows
    A_c.mult(d, y_cc)
    scale = 1e-13 * np.abs(y_f.array).max()
    assert np.allclose(y_cc.array[c], d.array[c], rtol=0, atol=1e-14)          # identity rows
    assert np.allclose(y_cc.array[~c], y_f.array[~c], rtol=1e-13, atol=scale)  # columns gone: K_ff d_f

    # the lifting: with prescribed g, the symmetric system's right-hand side gives the step of the
    # row elimination, K_ff δ_f = F_f - K_fc δ_c with δ_c = x_c - g
    g = x.array[c] - d.array[c]                           # so that δ_c = d_c
    disc.set_constraints(disc.constraints.owned)
    K = disc.create_matrix()
    disc.assemble_tangent(x, K)
    b = disc.create_vector()
    disc.residual(x, b)
    free = b.array[~c].copy()
    disc.constraints.set_residual_rows(x, b, g)
    assert np.array_equal(b.array[c], x.array[c] - g)
    assert np.array_equal(b.array[~c], free)
    disc.constraints.eliminate(K, b)
    assert np.allclose(b.array[c], x.array[c] - g, rtol=0, atol=1e-14)
    assert np.allclose(b.array[~c], free - y_c.array[~c], rtol=1e-13, atol=scale)
    K.mult(d, y_cc)                                       # and K is A_c: the same elimination
    assert np.allclose(y_cc.array[c], d.array[c], rtol=0, atol=1e-14)
    assert np.allclose(y_cc.array[~c], y_f.array[~c], rtol=1e-13, atol=scale)


def test_constraints_outside_the_local_unknowns_are_rejected():
    with pytest.raises(ValueError, match=r"constrained unknowns must lie in \[0, 4\)"):
        Constraints(np.array([1, 5]), 4, 4)
