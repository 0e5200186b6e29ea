"""The medium's skew penalty ``ThirdMedium(..., beta1=b)``: ``b/2 |w(F)|^2`` outside gamma.

A rigid rotation by theta has w = 2 sin(theta) about its axis and no strain and no second gradient,
so every discretization must give the energy ``b/2 (2 sin theta)^2 |Omega|`` of a medium block
(SFVEM and FEM, 2D and 3D), and the same block without the option none.
"""
import numpy as np
import pytest
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem.discretizations.fem import LagrangeDiscretization
from dolfinx_sfvem.discretizations.vem import SFVEMDiscretization
from dolfinx_sfvem.discretizations.vem3d import PolyhedralDiscretization
from dolfinx_sfvem.mesh.cell_mesh import CellMesh
from dolfinx_sfvem.mesh.polyhedron_mesh import PolyhedronMesh

BETA1, THETA = 0.7, 0.4
LENGTHS = (1.0, 0.5, 0.75)


def medium(beta1: float | None) -> sf.ThirdMedium:
    return sf.ThirdMedium(mu=0.5, K=1.0, gamma=1e-3, alpha_r=0.3, regularization="huhu", beta1=beta1)


def rotated(disc) -> "PETSc.Vec":  # noqa: F821
    """u = (R - I) x, R the rotation by THETA about z."""
    c, s = np.cos(THETA), np.sin(THETA)
    x = disc.x_nodes
    u = np.zeros_like(x)
    u[:, 0] = (c - 1) * x[:, 0] - s * x[:, 1]
    u[:, 1] = s * x[:, 0] + (c - 1) * x[:, 1]
    vec = disc.create_vector()
    with vec.localForm() as vl:
        vl.array[:] = u.ravel()
    return vec


def discretization(kind: str, beta1: float | None, tiny3d):
    materials = {1: medium(beta1)}
    if kind in ("vem2d", "fem2d"):
        mesh = sf.meshes.quad_rectangle(*LENGTHS[:2], 2, 2, tag=1)
        if kind == "vem2d":
            return SFVEMDiscretization(mesh, materials, MPI.COMM_WORLD, verbose=False)
        return LagrangeDiscretization.from_polygon_mesh(mesh, materials, MPI.COMM_WORLD, verbose=False)
    points, cells = tiny3d.hex_grid((2, 1, 1), LENGTHS)
    mesh = CellMesh(points, cells, np.ones(len(cells)), "hexahedron")
    if kind == "vem3d":
        return PolyhedralDiscretization(PolyhedronMesh.from_cell_mesh(mesh), materials, MPI.COMM_WORLD, verbose=False)
    return LagrangeDiscretization.from_cell_mesh(mesh, materials, MPI.COMM_WORLD, verbose=False)


@pytest.mark.parametrize("kind", ["vem2d", "fem2d", "vem3d", "fem3d"])
def test_rigid_rotation_costs_beta1_half_w_squared(kind, tiny3d):
    volume = np.prod(LENGTHS[:2] if kind.endswith("2d") else LENGTHS)
    expected = BETA1 / 2 * (2 * np.sin(THETA)) ** 2 * volume
    energies = {}
    for beta1 in (BETA1, None):
        disc = discretization(kind, beta1, tiny3d)
        energies[beta1] = disc.residual(rotated(disc), disc.create_vector()).energy
    assert abs(energies[None]) <= 1e-10 * expected, energies
    assert energies[BETA1] == pytest.approx(expected, rel=1e-10), (kind, energies)
