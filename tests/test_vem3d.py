"""The SFVEM discretization on polyhedra (dolfinx_sfvem/discretizations/vem3d.py): its tangent is the derivative of
its residual (energies with and without the second gradient, the cavity's swept volume, a follower
pressure), face loads land where the element's own flux does, and the output host reproduces
quadratics and is continuous across faces."""
import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

import dolfinx_sfvem as sf
from dolfinx_sfvem.physics.energy import VolumeWork
from dolfinx_sfvem.physics.face_loads import BoundFacePressure, BoundFaceTraction, loaded_facets
from dolfinx_sfvem.discretizations.polyhedral_space import FACE
from dolfinx_sfvem.discretizations.vem3d import PolyhedralDiscretization

K, MU = 5 / 3, 5 / 14


def two_regions() -> sf.meshes.PolyhedronMesh:
    """[0, 2] x [0, 1] x [0, 1]: an octree with its x < 1 half refined once (hanging vertices), the
    cells with centre z < 0.5 a solid (tag 1), the others third medium (tag 2)."""
    octree = sf.meshes.octree_box([0.0, 0.0, 0.0], [2.0, 1.0, 1.0], [2, 1, 1]).refine(lambda c: c[0] < 1.0)
    mesh = octree.polyhedra()
    mesh.tags[:] = np.where(mesh.centroids[:, 2] < 0.5, 1, 2)
    return mesh


def discretization(comm=MPI.COMM_SELF) -> PolyhedralDiscretization:
    medium = sf.ThirdMedium(mu=MU, K=K, gamma=0.1, alpha_r=0.05, regularization="huhu")
    return PolyhedralDiscretization(two_regions(), {1: sf.Hyperelastic(K=K, mu=MU), 2: medium}, comm, verbose=False)


def state(disc, scale=0.05, seed=0) -> PETSc.Vec:
    """A smooth displacement plus a little noise (every DOF kind moves)."""
    rng = np.random.default_rng(seed)
    x = disc.space.interpolate(lambda X: scale * np.stack([np.sin(X[1] + X[2]), X[0] * X[2], np.cos(X[0]) - 1.0]))
    with x.localForm() as xl:
        xl.array[:] += 1e-3 * rng.standard_normal(xl.array.size)
    return x


def directional_check(disc, x, force, stiffness, n_directions=3, h=1e-6) -> float:
    """Largest relative difference between K d and the central difference of the force along d."""
    A = disc.create_matrix()
    stiffness(x, A)
    worst = 0.0
    rng = np.random.default_rng(1)
    for _ in range(n_directions):
        d = disc.create_vector()
        d.setArray(rng.standard_normal(d.getLocalSize()))
        d.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        Kd = disc.create_vector()
        A.mult(d, Kd)
        sides = []
        for sign in (1.0, -1.0):
            y = x.copy()
            y.axpy(sign * h, d)
            y.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
            b = disc.create_vector()
            force(y, b)
            sides.append(b.getArray().copy())
        fd = (sides[0] - sides[1]) / (2 * h)
        worst = max(worst, np.abs(fd - Kd.getArray()).max() / np.abs(fd).max())
    return worst


def test_tangent_is_the_derivative_of_the_residual():
    disc = discretization()
    term = disc.add_energy_term(2, VolumeWork(p=0.3, uses_gradient=True))
    assert term.params["p"] == 0.3
    x = state(disc)
    assert directional_check(disc, x, disc.residual, disc.assemble_tangent) < 1e-6


def test_follower_pressure_stiffness_is_the_derivative_of_its_force():
    disc = discretization()
    top = loaded_facets(disc, lambda X: np.isclose(X[2], 1.0), "top")
    load = BoundFacePressure("top", disc, top, 0.2, follower=True)
    x = state(disc)

    def force(y, b):
        f = np.zeros((disc.n_local_nodes, 3))
        with y.localForm() as yl:
            load.add_force(yl.array_r.reshape(-1, 3), f)
        b.setArray(f.ravel()[:b.getLocalSize()])

    def stiffness(y, A):
        with y.localForm() as yl:
            load.add_stiffness(yl.array_r.reshape(-1, 3), A, 1.0)
        A.assemble()

    assert directional_check(disc, x, force, stiffness) < 1e-6


def test_a_constant_traction_lands_on_the_face_means():
    """∫_f t · Π^∇_{2,f} v dA: the force of a constant traction is t |f| on each loaded face's
    mean DOF and zero on its vertices and edge midpoints, as the element's flux of a homogeneous
    stress (whose equilibrium the patch test needs)."""
    disc = discretization()
    end = loaded_facets(disc, lambda X: np.isclose(X[0], 2.0), "end")
    t = np.array([0.3, -0.1, 0.2])
    f = np.zeros((disc.n_local_nodes, 3))
    BoundFaceTraction("end", disc, end, t).add_force(None, f)
    on_end = np.isclose(disc.x_nodes[:, 0], 2.0)
    means = on_end & (disc.space.node_kind == FACE)
    assert np.abs(f[on_end & ~means]).max() < 1e-14
    assert f[means] == pytest.approx(t[None, :], abs=1e-14)       # the coarse cube's unit face at x = 2
    assert np.abs(f[~on_end]).max() < 1e-14


def test_output_host_is_continuous_and_exact_for_quadratics():
    disc = discretization()
    quadratic = lambda X: np.stack([X[0] ** 2, X[1] * X[2], X[0] * X[1] - X[2] ** 2])  # noqa: E731
    x = disc.space.interpolate(quadratic, degree=2)
    u = disc.output_function(x)
    X = disc.V.tabulate_dof_coordinates()
    assert u.x.array.reshape(-1, 3) == pytest.approx(quadratic(X.T).T, abs=1e-12)
    keys, values = disc.output_state(x)
    points = keys < disc.output_mesh.n_points
    assert values[points] == pytest.approx(quadratic(disc.output_mesh.points[keys[points]].T).T, abs=1e-12)
