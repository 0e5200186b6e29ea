"""Loads on the faces of a 3D mesh (the counterpart of :mod:`~dolfinx_sfvem.physics.edge_loads`):
traction, dead and follower pressure as UFL exterior-facet forms on the discretization's *host*
space, and the open faces of a cavity pressure's region.

The host (``disc.load_space``) is a P2 space on the discretization's DOLFINx mesh of tetrahedra
or hexahedra (``disc.dolfinx_mesh``): the Lagrange discretization's own space, or for the SFVEM on
polyhedra the discontinuous P2 space of its fan mesh, where the state is T u with each face's
projection of its trace on the face (:mod:`~dolfinx_sfvem.discretizations.vem3d`). The
discretization is a :class:`~dolfinx_sfvem.discretizations.load_host.LoadHost`: it moves values
between its unknowns and the host (``to_host``, ``add_from_host``, ``add_host_matrix``,
``nodes_of_host``: the identity for the Lagrange one), so one form serves both methods.

The faces a load acts on are facet tags built from ``where`` (:func:`loaded_facets`). On the
quadratic faces (P2 triangles, Q2 quadrilaterals) the forces at λ = 1 are, with N the reference
outward normal, dA the reference area and F = I + ∇u,

================  =========================================  =================================================
load              force                                      work-conjugate displacement
================  =========================================  =================================================
traction          ∫ t · v dA (dead)                          ∫ t · u dA / (|t| A)
dead pressure     −p ∫ v · N dA                              ∫ u · (−N) dA
follower          −p ∫ v · J F⁻ᵀ N dA (Nanson: n da)         the volume swept into the body
================  =========================================  =================================================

The follower load's stiffness is ``ufl.derivative`` of its form. The swept volume is exact for
straight paths x(s) = X + s u, s ∈ [0, 1]: −∫ u · (∫₀¹ cof(I + s H) ds) N dA with H = ∇u and
∫₀¹ cof(I + s H) ds = I + ½ (tr H I − Hᵀ) + ⅓ cof H (cof(I + sH) is quadratic in s in 3D).
Forms are integrated with the rule of degree ``disc.face_quadrature_degree`` (exact for the dead loads).
"""
from __future__ import annotations


import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.fem
import dolfinx.fem.petsc
import dolfinx.mesh

from dolfinx_sfvem import _compat
from dolfinx_sfvem.discretizations.compile_lock import compiled_form
from dolfinx_sfvem.discretizations.discretization import Discretization
from dolfinx_sfvem.physics.energy import VolumeWork
from dolfinx_sfvem.physics.bound_load import BoundLoad, CavityPressureTerm, largest_entry

#: the tag of the loaded facets in a load's facet tags
LOADED = 1


def cofactor(A: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """cof A = det(A) A⁻ᵀ of a 3 x 3 expression, written out (defined for singular A)."""
    return ufl.as_matrix([[A[(i + 1) % 3, (j + 1) % 3] * A[(i + 2) % 3, (j + 2) % 3]
                           - A[(i + 1) % 3, (j + 2) % 3] * A[(i + 2) % 3, (j + 1) % 3] for j in range(3)]
                          for i in range(3)])


def mean_cofactor(H: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """∫₀¹ cof(I + s H) ds = I + ½ (tr H I − Hᵀ) + ⅓ cof H of a 3 x 3 expression (module docstring)."""
    return ufl.Identity(3) + (ufl.tr(H) * ufl.Identity(3) - H.T) / 2 + cofactor(H) / 3


def exterior_facets(mesh: dolfinx.mesh.Mesh) -> np.ndarray:
    """Local facets on the boundary of the (whole) mesh."""
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    return np.asarray(dolfinx.mesh.exterior_facet_indices(mesh.topology), dtype=np.int32)


def of_owned_cells(mesh: dolfinx.mesh.Mesh, facets: np.ndarray) -> np.ndarray:
    """The ``facets`` (local) of at least one owned cell: a ghosted mesh's outer ghost layer has
    facets with one local cell that are not on the boundary of the mesh."""
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    f2c = mesh.topology.connectivity(tdim - 1, tdim)
    offsets, links = np.asarray(f2c.offsets), np.asarray(f2c.array)
    owned = links < _compat.num_owned_cells(mesh)
    has_owned = np.add.reduceat(owned, offsets[:-1]) > 0 if links.size else np.zeros(0, dtype=bool)
    return facets[has_owned[facets]]


def facet_normal_axes(mesh: dolfinx.mesh.Mesh, facets: np.ndarray) -> np.ndarray:
    """Per facet the axis (0, 1, 2) it is normal to (a facet in a plane x = const is normal to
    axis 0), -1 for a facet off the coordinate planes."""
    nodes = _compat.entity_geometry_nodes(mesh, mesh.topology.dim - 1, facets)
    x = mesh.geometry.x[nodes]
    extent = np.ptp(x, axis=1) if len(x) else np.zeros((0, 3))
    flat = extent <= 1e-10 * extent.max(axis=1, keepdims=True, initial=0.0)
    return np.where(flat.sum(axis=1) == 1, np.argmax(flat, axis=1), -1)


#: vertices of a facet of each cell type (a facet's geometry nodes list them first)
_FACET_VERTICES = {"triangle": 2, "quadrilateral": 2, "tetrahedron": 3, "hexahedron": 4}


def facet_vertex_centres(mesh: dolfinx.mesh.Mesh, facets: np.ndarray) -> np.ndarray:
    """The means (m, 3) of the vertices of the local ``facets`` (m,): on the flat facet through them,
    also on a degree-2 mesh (where DOLFINx's facet midpoints average the curved edge nodes too)."""
    nodes = _compat.entity_geometry_nodes(mesh, mesh.topology.dim - 1, np.asarray(facets, dtype=np.int32))
    corners = nodes[:, :_FACET_VERTICES[mesh.topology.cell_type.name]]
    return mesh.geometry.x[corners].mean(axis=1) if len(corners) else np.zeros((0, 3))


def loaded_facets(disc: Discretization, where, name: str) -> np.ndarray:
    """The local boundary facets of ``disc.dolfinx_mesh`` that ``where`` selects (collective): a marker
    of coordinates (3, n) -> (n,) bool (the facets whose geometry nodes and vertices' mean it selects), or
    region tags (the mesh-boundary facets of their cells).

    Raises
    ------
    ValueError
        If the marker selects a facet inside the mesh (naming its midpoint) or nothing is selected.
    """
    mesh = disc.dolfinx_mesh
    fdim = mesh.topology.dim - 1
    boundary = exterior_facets(mesh)
    if callable(where):
        def marked(facets):
            facets = np.asarray(facets, dtype=np.int32)
            return facets[np.asarray(where(facet_vertex_centres(mesh, facets).T), dtype=bool).reshape(-1)]
        every = of_owned_cells(mesh, marked(dolfinx.mesh.locate_entities(mesh, fdim, lambda x: where(x[:3]))))
        inner = np.setdiff1d(every, boundary)
        found = [tuple(np.round(facet_vertex_centres(mesh, inner[:1])[0], 12) + 0.0)] if inner.size else []
        found = [f for part in disc.comm.allgather(found) for f in part]
        if found:
            raise ValueError(f"load {name!r}: the marker selects the face with midpoint {found[0]}, which is not on "
                             "the boundary of the mesh; tractions and pressures act on boundary faces only (fill a "
                             "closed cavity with third medium and use cavity_pressure for a pressure inside the mesh)")
        chosen = np.intersect1d(every, boundary)
    else:
        tdim = fdim + 1
        f2c = mesh.topology.connectivity(fdim, tdim)
        cells = np.array([f2c.links(f)[0] for f in boundary], dtype=np.int64)
        chosen = boundary[np.isin(disc.cell_tag[cells], np.asarray(where))] if cells.size else boundary
    if disc.comm.allreduce(int(chosen.size), op=MPI.SUM) == 0:
        raise ValueError(f"load {name!r} selects no boundary face")
    return chosen.astype(np.int32)


def surface_boundary_edges(mesh: dolfinx.mesh.Mesh, facets: np.ndarray, comm: MPI.Comm) -> np.ndarray:
    """The local edges (mesh entities of dimension 1) of the boundary curve of the surface made of
    the loaded ``facets`` (local): the edges of exactly one loaded facet, counted over all ranks
    (each facet by its owner; edges named by their global vertex pair). Empty for a closed
    surface (collective). Creates the mesh's edges and their connectivity to vertices and cells."""
    topology = mesh.topology
    for dims in ((2, 1), (1, 0), (1, 3)):       # edge -> cell: for locating the edges' dofs (DOLFINx 0.11)
        topology.create_connectivity(*dims)
    f2e, e2v = topology.connectivity(2, 1), topology.connectivity(1, 0)
    per_facet = int(f2e.offsets[1] - f2e.offsets[0]) if len(f2e.offsets) > 1 else 3
    facet_edges = np.asarray(f2e.array).reshape(-1, per_facet)
    edges = np.unique(facet_edges[facets])

    def keys(local_edges):
        vertices = np.asarray(e2v.array).reshape(-1, 2)[local_edges].reshape(-1)
        global_vertices = np.asarray(topology.index_map(0).local_to_global(vertices.astype(np.int32)))
        return np.sort(global_vertices.reshape(-1, 2).astype(np.int64), axis=1)
    owned = facets[facets < topology.index_map(2).size_local]
    counted = [k for part in comm.allgather(keys(facet_edges[owned].reshape(-1))) for k in part]
    counted = np.asarray(counted, dtype=np.int64).reshape(-1, 2)
    unique, count = np.unique(counted, axis=0, return_counts=True)
    once = {tuple(k) for k in unique[count == 1].tolist()}
    return edges[[tuple(k) in once for k in keys(edges).tolist()]].astype(np.int32)


class FaceForms:
    """The UFL forms of a face load on the loaded facets (module docstring); evaluated at the
    state given to :meth:`set_state`."""

    def __init__(self, disc: Discretization, facets: np.ndarray):
        self.disc = disc
        mesh = disc.dolfinx_mesh
        tags = _compat.create_facet_tags(mesh, facets, np.full(facets.size, LOADED, dtype=np.int32))
        self.ds = ufl.Measure("ds", domain=mesh, subdomain_data=tags,
                              metadata={"quadrature_degree": disc.face_quadrature_degree})(LOADED)
        self.u = dolfinx.fem.Function(disc.load_space)
        self.v = ufl.TestFunction(disc.load_space)
        self.N = ufl.FacetNormal(mesh)
        self.F = ufl.Identity(3) + ufl.grad(self.u)
        self.scale = dolfinx.fem.Constant(mesh, PETSc.ScalarType(1.0))
        self._vector = _compat.create_petsc_vector(disc.load_space.dofmap.index_map, 3)

    def set_state(self, u: np.ndarray | None) -> None:
        """u (n_local_nodes, 3) of the local nodes, None: the reference state."""
        self.u.x.array[:] = 0.0 if u is None else self.disc.to_host(u)
        self.u.x.scatter_forward()

    def add_vector(self, form: dolfinx.fem.Form, f: np.ndarray) -> None:
        """f (n_local_nodes, 3) += the local (owned and ghost) entries of the assembled ``form``,
        taken from the host space to the unknowns (``disc.add_from_host``)."""
        with self._vector.localForm() as vl:
            vl.set(0.0)
        dolfinx.fem.petsc.assemble_vector(self._vector, form)
        self.disc.add_from_host(self._vector, f)

    def scalar(self, form: dolfinx.fem.Form) -> float:
        """The form's value over all ranks (collective)."""
        return float(self.disc.comm.allreduce(dolfinx.fem.assemble_scalar(form), op=MPI.SUM))

    def swept_volume(self) -> ufl.Form:
        """The volume swept into the body by the faces along straight paths (module docstring)."""
        return -ufl.dot(self.u, mean_cofactor(ufl.grad(self.u)) * self.N) * self.ds


# --------------------------------------------------------------------------- bound loads
class BoundFaceTraction(BoundLoad):
    """Dead traction ``t`` (3,) per unit reference area on the loaded faces."""

    def __init__(self, name: str, disc: Discretization, facets: np.ndarray, t: np.ndarray):
        super().__init__(name, disc)
        self.forms = FaceForms(disc, facets)
        self.t_norm = float(np.linalg.norm(t))
        t = ufl.as_vector([float(c) for c in t])
        self._force = compiled_form(ufl.dot(t, self.forms.v) * self.forms.ds)
        self._work = compiled_form(ufl.dot(t, self.forms.u) * self.forms.ds)
        area = self.forms.scalar(compiled_form(self.forms.scale * self.forms.ds))
        self.magnitude = self.t_norm * area
        self.reference_norm = largest_entry(self, None)

    def add_force(self, u: np.ndarray | None, f: np.ndarray) -> None:
        self.forms.add_vector(self._force, f)

    def measure(self, x: PETSc.Vec, load: float) -> dict[str, float]:
        with x.localForm() as xl:
            self.forms.set_state(xl.array_r)
        work = self.forms.scalar(self._work)
        return {"magnitude": load * self.magnitude, "displacement": work / self.magnitude if self.magnitude else 0.0}


class BoundFacePressure(BoundLoad):
    """Pressure ``p`` on the loaded faces, pushing into the body for p > 0: on the deformed faces
    (``follower``, with its load stiffness) or on the reference normal."""

    def __init__(self, name: str, disc: Discretization, facets: np.ndarray, p: float, follower: bool):
        super().__init__(name, disc)
        self.p = p
        self.follows = self.has_stiffness = follower
        forms = self.forms = FaceForms(disc, facets)
        #: the local nodes (two vertices, the mid-edge node) of every local edge of the loaded
        #: surface's boundary curve (m, 3)
        self.curve_nodes = np.zeros((0, 3), dtype=np.int64)
        if follower and disc.continuous_face_traces:
            curve = surface_boundary_edges(disc.dolfinx_mesh, facets, disc.comm)
            self.curve_nodes = np.array([dolfinx.fem.locate_dofs_topological(disc.V, 1, np.array([e], dtype=np.int32),
                                                                             remote=False)    # local: not collective
                                         for e in curve], dtype=np.int64).reshape(-1, 3)
        if follower:
            force = -p * ufl.dot(cofactor(forms.F) * forms.N, forms.v) * forms.ds
            self._stiffness = compiled_form(forms.scale * ufl.derivative(force, forms.u,
                                                                         ufl.TrialFunction(disc.load_space)))
            self._conjugate = compiled_form(forms.swept_volume())
        else:
            force = -p * ufl.dot(forms.N, forms.v) * forms.ds
            self._conjugate = compiled_form(-ufl.dot(forms.u, forms.N) * forms.ds)
        self._force = compiled_form(force)
        self.reference_norm = largest_entry(self, None)

    def symmetric_with(self, constrained: np.ndarray) -> bool:
        """Whether the load stiffness is symmetric once the unknowns ``constrained`` (local mask
        (n_local_dofs,), 3 per node) are eliminated (collective): a dead pressure always; a
        follower one when the boundary term ∮ p (δu × Δu) · dx of its stiffness's skew part
        vanishes on every edge of the loaded surface's boundary curve (none on a closed
        surface). On an edge it does when the
        components constrained at all of its nodes are

        - two or three: δu and Δu are both along the free axis (or 0), δu × Δu = 0;
        - the one normal to a plane x_k = const that holds the edge (a symmetry plane with its
          normal displacement fixed): δu × Δu is along e_k, the deformed edge stays in the
          plane, dx ⊥ e_k.

        Otherwise (a free edge, one constrained component across the edge) it is reported as not
        symmetric, and the solver uses LU. So is every follower pressure of a discretization whose
        load space holds each face's own trace (``disc.continuous_face_traces`` False, the SFVEM on
        polyhedra): two faces' traces differ along their common edge, whose skew terms then do not
        cancel, and an edge's held DOFs do not hold the face's projected trace there."""
        if not self.follows:
            return True
        if not self.disc.continuous_face_traces:       # the SFVEM: each face's own trace, see below
            return False
        nodes = self.curve_nodes
        held = constrained[3 * nodes[:, :, None] + np.arange(3)].all(axis=1)              # (m, 3)
        x = self.disc.x_nodes[nodes]                                                      # (m, k, 3)
        extent = np.ptp(x, axis=1)
        in_plane = extent <= 1e-10 * np.maximum(extent.max(axis=1, keepdims=True, initial=0.0), 1e-300)
        vanishing = (held.sum(axis=1) >= 2) | np.any(held & in_plane, axis=1)
        return not self.comm.allreduce(bool(np.any(~vanishing)), op=MPI.LOR)

    def add_force(self, u: np.ndarray | None, f: np.ndarray) -> None:
        self.forms.set_state(u)
        self.forms.add_vector(self._force, f)

    def add_stiffness(self, u: np.ndarray, A: PETSc.Mat, scale: float) -> None:
        self.forms.set_state(u)
        self.forms.scale.value = scale
        self.disc.add_host_matrix(A, self._stiffness)

    def measure(self, x: PETSc.Vec, load: float) -> dict[str, float]:
        with x.localForm() as xl:
            self.forms.set_state(xl.array_r)
        return {"magnitude": load * self.p, "displacement": self.forms.scalar(self._conjugate)}


class BoundCavityPressure3D(CavityPressureTerm):
    """The energy term −λ p ∫ (J − 1) dΩ over a medium region of a 3D mesh; its faces on the mesh
    boundary (``open_facets``, local) must lie in planes x, y or z = const (symmetry planes)."""

    def __init__(self, name: str, disc: Discretization, term, p: float, open_facets: np.ndarray, axes: np.ndarray):
        super().__init__(name, disc, term, p)
        fdim = disc.dolfinx_mesh.topology.dim - 1
        #: per axis k, the local nodes on the open faces normal to it
        self.open_nodes = [disc.nodes_of_host(dolfinx.fem.locate_dofs_topological(disc.V, fdim, open_facets[axes == k]))
                           for k in range(3)]

    def check_constraints(self, constrained: np.ndarray) -> None:
        """ValueError naming a node on an open face of the region whose displacement normal to the
        face is not constrained."""
        free = [(k, nodes[~constrained[3 * nodes + k]]) for k, nodes in enumerate(self.open_nodes)]
        found = [(k, tuple(np.round(self.disc.x_nodes[nodes[0]], 12) + 0.0)) for k, nodes in free if nodes.size][:1]
        found = [f for part in self.comm.allgather(found) for f in part]
        if found:
            k, x = found[0]
            raise ValueError(f"cavity pressure {self.name!r}: region {self.term.tag} is not closed: its face through "
                             f"the node {x} lies on the boundary of the mesh without u_{'xyz'[k]} fixed there (a "
                             "symmetry plane closes a cavity only with its normal displacement fixed)")


def bind_cavity_pressure(name: str, disc: Discretization, tag: int, p: float, uses_gradient: bool) -> BoundLoad:
    """The cavity pressure of :class:`~dolfinx_sfvem.physics.loads.CavityPressure` on a 3D mesh (collective)."""
    mesh = disc.dolfinx_mesh
    boundary = exterior_facets(mesh)
    f2c = mesh.topology.connectivity(mesh.topology.dim - 1, mesh.topology.dim)
    cells = np.array([f2c.links(f)[0] for f in boundary], dtype=np.int64)
    open_facets = boundary[disc.cell_tag[cells] == tag] if cells.size else boundary
    axes = facet_normal_axes(mesh, open_facets)
    skew = [tuple(np.round(dolfinx.mesh.compute_midpoints(mesh, mesh.topology.dim - 1, open_facets[axes < 0][:1])[0],
                           12) + 0.0)] if np.any(axes < 0) else []
    skew = [s for part in disc.comm.allgather(skew) for s in part]
    if skew:
        raise ValueError(f"cavity pressure {name!r}: region {tag} is not closed: its face with midpoint {skew[0]} lies "
                         "on the boundary of the mesh off the planes x, y, z = const (a cavity must be enclosed by "
                         "other regions or by symmetry planes; use pressure() on an open boundary)")
    term = disc.add_energy_term(tag, VolumeWork(p=0.0, uses_gradient=uses_gradient))
    return BoundCavityPressure3D(name, disc, term, float(p), open_facets, axes)
