"""What the loads on faces and the enclosed volume need of a 3D discretization: the *load host*.

The loads on the faces of a 3D mesh (:mod:`~dolfinx_sfvem.physics.face_loads`) and the volume
enclosed by a region (:mod:`~dolfinx_sfvem.physics.enclosed_volume`) are UFL forms on a P2 space
of a DOLFINx mesh, the *load space*. A discretization that hosts them moves values between its
unknowns and that space. :class:`LoadHost` declares this, besides the members of
:class:`~dolfinx_sfvem.discretizations.discretization.Discretization` the loads also use (``comm``,
``x_nodes``, ``dolfinx_mesh``, ``add_energy_term``, ...). The load space lives on the
discretization's ``dolfinx_mesh``.

Implemented by :class:`~dolfinx_sfvem.discretizations.fem.LagrangeDiscretization` (its own P2/Q2
space: every map is the identity) and
:class:`~dolfinx_sfvem.discretizations.vem3d.PolyhedralDiscretization` (discontinuous P2 on the
fan mesh, each face's projection of its trace on the face: the maps are T and Tᵀ). The 2D
discretizations need none of it: loads on 2D boundaries are edge integrals on the unknowns' own
nodes (:mod:`~dolfinx_sfvem.physics.edge_loads`).

Below, n is the number of local (owned and ghost) nodes of the unknowns, 3 components each, and
m the number of local nodes of :attr:`LoadHost.load_space`.
"""
from __future__ import annotations

import typing

import numpy as np
from petsc4py import PETSc

import dolfinx.fem


class LoadHost(typing.Protocol):
    """The members the loads on faces and the enclosed volume use (module docstring).

    Attributes
    ----------
    V : dolfinx.fem.FunctionSpace
        The continuous vector P2 (Q2) space on ``dolfinx_mesh`` whose nodes at the mesh's vertices,
        edges and faces carry the unknowns' nodes there (:meth:`nodes_of_host` maps them); the
        space of ``output_function``. Its DOFs located on facets or edges
        (``dolfinx.fem.locate_dofs_topological``) name the nodes on a loaded surface.
    cell_tag : (n_local_cells,) int64
        Region tag of every local (owned and ghost) cell of ``dolfinx_mesh``.
    face_quadrature_degree : int
        Degree of the quadrature rule of the load space's facet forms (exact for the dead loads
        on P2/Q2 traces).
    continuous_face_traces : bool
        Whether the load space's traces are continuous across the faces' edges (one value per
        node there): true for a Lagrange space; false where each face holds its own trace, which
        makes a follower pressure's stiffness unsymmetric along the edges.
    """

    V: dolfinx.fem.FunctionSpace
    cell_tag: np.ndarray
    face_quadrature_degree: int
    continuous_face_traces: bool

    @property
    def load_space(self) -> dolfinx.fem.FunctionSpace:
        """The space on which the load forms are written: vector P2 (Q2) on ``dolfinx_mesh``, block
        size 3, m nodes on this rank."""

    def to_host(self, u: np.ndarray) -> np.ndarray:
        """The load-space values (3 m,) of the nodal values ``u`` (n, 3): those of the owned cells
        at least (the caller scatters them to the ghosts)."""

    def add_from_host(self, host: PETSc.Vec, f: np.ndarray) -> None:
        """f (n, 3) += the transpose map of ``host``, a vector of the load space assembled on
        this rank (ghost contributions not yet accumulated); only what this rank owns of f is
        complete (the caller accumulates f's ghost entries)."""

    def add_host_matrix(self, A: PETSc.Mat, form: dolfinx.fem.Form, scale: float = 1.0) -> None:
        """A += scale Mᵀ K M: K the assembled bilinear ``form`` (compiled) on the load space, M
        the map of :meth:`to_host` (collective). A is the unknowns' matrix; the caller assembles
        it afterwards."""

    def nodes_of_host(self, nodes: np.ndarray) -> np.ndarray:
        """The local nodes (k,) int64 of the unknowns carried by the local nodes ``nodes`` of
        :attr:`V` (those of them that carry one)."""
