"""Linear solver presets and the rigid-body near-nullspace (dolfinx_sfvem/linear_solvers.py)."""
import numpy as np
import pytest
from petsc4py import PETSc

import dolfinx_sfvem as sf
from dolfinx_sfvem.linear_solvers import linear_solver_options, rigid_body_modes

SOLID = sf.Hyperelastic(K=5 / 3, mu=5 / 14)


def block() -> sf.PolygonMesh:
    return sf.meshes.quad_rectangle(1.0, 0.5, 6, 3, tag=1)


@pytest.mark.mpi
@pytest.mark.parametrize("method", ["vem", "fem"])
def test_rigid_body_modes_are_the_kernel_of_the_unconstrained_tangent(method):
    """The modes are orthonormal and K r = 0 (to round-off) for the tangent of a free body at rest."""
    problem = sf.ContactProblem(block(), {1: SOLID}, method=method, verbose=False)
    disc = problem.disc
    modes = rigid_body_modes(disc.x_nodes, disc.n_owned_nodes, disc.create_vector)
    vectors = modes.getVecs()
    assert len(vectors) == 3
    gram = np.array([[a.dot(b) for b in vectors] for a in vectors])
    np.testing.assert_allclose(gram, np.eye(3), atol=1e-12)
    A = disc.create_matrix()
    x = disc.create_vector()
    x.set(0.0)
    disc.assemble_tangent(x, A)
    y = A.createVecLeft()
    for r in vectors:
        A.mult(r, y)
        assert y.norm() < 1e-10 * A.norm(PETSc.NormType.INFINITY)


def test_unknown_linear_solver_is_named():
    with pytest.raises(ValueError, match="'cholesky'.*direct"):
        linear_solver_options("cholesky")
    with pytest.raises(ValueError, match="linear solver"):
        sf.ContactProblem(block(), {1: SOLID}, method="fem", linear_solver="amg", verbose=False)


@pytest.mark.parametrize("method", ["vem", "fem"])
def test_iterative_solver_gives_the_direct_answer_on_a_solid(method):
    """GMRES + GAMG (with the near-nullspace) and MUMPS reach the same state on a compressed block."""
    answers = []
    for linear_solver in ("direct", "iterative"):
        problem = sf.ContactProblem(block(), {1: SOLID}, method=method, linear_solver=linear_solver, verbose=False)
        problem.fix(lambda x: np.isclose(x[1], 0.0))
        problem.prescribe(lambda x: np.isclose(x[1], 0.5), ux=0.05, uy=-0.1, name="top")
        result = problem.solve(steps=2)
        assert result.converged
        answers.append(np.asarray(result.steps[-1]["reaction"]["top"]))
    np.testing.assert_allclose(answers[1], answers[0], rtol=1e-7)
