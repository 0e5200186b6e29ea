"""The discretization contract (dolfinx_sfvem.discretization, docs/architecture.md), for both methods.

- Both classes implement every abstract member.
- Constraints registered once: constrained rows of the tangent are identity rows with the columns
  kept, the free rows unchanged; the residual rows of the constrained unknowns become x_c - g_c.
- Constrained unknowns outside the rank's range are rejected by name.
"""
import numpy as np
import pytest
from mpi4py import MPI

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
def test_registered_constraints_eliminate_rows(method):
    disc = discretization(method)
    x, d = state(disc), direction(disc)
    A, A_c = disc.create_matrix(), disc.create_matrix()
    disc.jacobian(x, A)                                   # nothing registered: the plain tangent
    disc.set_constraints(disc.locate_dofs(lambda X: np.isclose(X[0], 0.0) | np.isclose(X[1], 1.0), component=1))
    disc.jacobian(x, A_c)
    y, y_c = disc.create_vector(), disc.create_vector()
    A.mult(d, y)
    A_c.mult(d, y_c)
    c = disc.constraints.mask[:disc.n_owned_dofs]
    assert MPI.COMM_WORLD.allreduce(int(c.sum()), op=MPI.SUM) > 0
    assert np.array_equal(np.flatnonzero(c), disc.constraints.owned)
    assert np.allclose(y_c.array[c], d.array[c], rtol=0, atol=1e-14)
    assert np.allclose(y_c.array[~c], y.array[~c], rtol=1e-13, atol=1e-13 * np.abs(y.array).max())

    b = disc.create_vector()
    disc.residual(x, b)
    free = b.array[~c].copy()
    g = np.linspace(-1.0, 1.0, disc.constraints.owned.size)
    disc.constraints.set_residual_rows(x, b, g)
    assert np.array_equal(b.array[c], x.array[c] - g)
    assert np.array_equal(b.array[~c], free)


def test_constraints_outside_the_local_unknowns_are_rejected():
    with pytest.raises(ValueError, match=r"constrained unknowns must lie in \[0, 4\)"):
        Constraints(np.array([1, 5]), 4, 4)
