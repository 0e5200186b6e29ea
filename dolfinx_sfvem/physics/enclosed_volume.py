"""The volume enclosed by a region's deformed boundary, for the cavity pressure on polyhedra.

The 3D counterpart of :mod:`~dolfinx_sfvem.physics.enclosed_area`. The cavity pressure's energy
−p ∫_R (J − 1) dΩ over a medium region R is, by the divergence theorem, −p ΔV with ΔV the volume
swept by R's boundary. With straight paths x(s) = X + s u (s ∈ [0, 1])

    ΔV = ∫_∂R u · (∫₀¹ cof(I + s ∇u) ds) N dA,   ∫₀¹ cof(I + sH) ds = I + ½ (tr H I − Hᵀ) + ⅓ cof H,

exact because cof(I + sH) is quadratic in s; cof(F) N = F t₁ × F t₂ (N = t₁ × t₂) depends on the
trace on the face and its tangential derivatives only. The SFVEM on polyhedra evaluates it on the
face projections of its faces (the load space of :mod:`~dolfinx_sfvem.discretizations.vem3d`), where the projected
gradient Π⁰_l ∇u would make ∫ det F depend on the polyhedra's interior DOFs and give the tangent
spurious negative directions. On R's faces on a symmetry plane (u · N = 0, in-plane motion) the
integrand vanishes, so only the faces between R and the other regions enter.
"""
from __future__ import annotations

import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.fem
import dolfinx.fem.petsc

from dolfinx_sfvem import _compat
from dolfinx_sfvem.discretizations.compile_lock import compiled_form
from dolfinx_sfvem.discretizations.discretization import Discretization
from dolfinx_sfvem.physics.face_loads import mean_cofactor

#: the tag of a region's interface facets in their facet tags
INTERFACE = 1


def interface_facets(mesh: dolfinx.mesh.Mesh, inside: np.ndarray) -> np.ndarray:
    """Local facets with one cell in the region and one outside (``inside`` (n_local_cells,) bool)."""
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    f2c = mesh.topology.connectivity(tdim - 1, tdim)
    offsets = np.asarray(f2c.offsets)
    links = np.asarray(f2c.array)
    two = np.flatnonzero(np.diff(offsets) == 2)
    first, second = inside[links[offsets[two]]], inside[links[offsets[two] + 1]]
    return two[first != second].astype(np.int32)


class EnclosedVolume:
    """ΔV of a region and its derivatives on a discretization's load space (``disc.load_space``,
    ``to_host``, ``add_from_host``, ``add_host_matrix`` of
    :class:`~dolfinx_sfvem.discretizations.load_host.LoadHost`).

    Parameters
    ----------
    disc
        The discretization (the SFVEM on polyhedra), a load host.
    tag
        The region.
    """

    def __init__(self, disc: Discretization, tag: int):
        self.disc = disc
        mesh, W = disc.dolfinx_mesh, disc.load_space
        inside = np.asarray(disc.cell_tag == tag)
        facets = interface_facets(mesh, inside)
        tags = _compat.create_facet_tags(mesh, facets, np.full(facets.size, INTERFACE, dtype=np.int32))
        dS = ufl.Measure("dS", domain=mesh, subdomain_data=tags,
                         metadata={"quadrature_degree": disc.face_quadrature_degree})(INTERFACE)
        Q = _compat.scalar_function_space(mesh, 0, "DG")
        chi = dolfinx.fem.Function(Q)
        chi.x.array[_compat.cell_dofs(Q)[:, 0]] = inside.astype(np.float64)
        self.u = dolfinx.fem.Function(W)
        N = ufl.FacetNormal(mesh)
        H = ufl.grad(self.u)

        def swept(side):
            return chi(side) * ufl.dot(self.u(side), mean_cofactor(H(side)) * N(side))

        volume = (swept("+") + swept("-")) * dS
        force = ufl.derivative(volume, self.u, ufl.TestFunction(W))
        self._volume = compiled_form(volume)
        self._force = compiled_form(force)
        self._tangent = compiled_form(ufl.derivative(force, self.u, ufl.TrialFunction(W)))
        self._vector = _compat.create_petsc_vector(W.dofmap.index_map, 3)

    def set_state(self, u: np.ndarray) -> None:
        """u (n_local_nodes, 3) of the local nodes."""
        self.u.x.array[:] = self.disc.to_host(u)
        self.u.x.scatter_forward()

    def add_force(self, u: np.ndarray, scale: float, f: np.ndarray) -> float:
        """f (n_local_nodes, 3) += scale ∂ΔV/∂u at u (ghosts accumulated by the caller); returns
        this rank's part of scale ΔV."""
        self.set_state(u)
        with self._vector.localForm() as vl:
            vl.set(0.0)
        dolfinx.fem.petsc.assemble_vector(self._vector, self._force)
        self._vector.scale(scale)
        self.disc.add_from_host(self._vector, f)
        return scale * float(dolfinx.fem.assemble_scalar(self._volume))

    def add_tangent(self, u: np.ndarray, scale: float, A: PETSc.Mat) -> None:
        """A += scale ∂²ΔV/∂u² at u (assembled; collective)."""
        self.set_state(u)
        self.disc.add_host_matrix(A, self._tangent, scale)

    def volume(self, u: np.ndarray, comm: MPI.Comm) -> float:
        """ΔV at u over all ranks (collective)."""
        self.set_state(u)
        return comm.allreduce(float(dolfinx.fem.assemble_scalar(self._volume)), op=MPI.SUM)
