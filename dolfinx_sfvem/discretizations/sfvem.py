"""What the SFVEM on polygons (:mod:`~dolfinx_sfvem.discretizations.vem`) and on polyhedra
(:mod:`~dolfinx_sfvem.discretizations.vem3d`) share, written once for d = 2 and 3.

The space (:class:`~dolfinx_sfvem.discretizations.space.SFVEMNodes`) owns the nodes, the
projections and the energy quadrature of its local cells; the discretization (:class:`OnSFVEMNodes`)
compiles each region's energy (:class:`Region`), tabulates the projected basis derivatives at the
quadrature points and runs the steps common to both dimensions: the matrix, the residual with its
smallest J, the tangent's loop over the regions and energy terms, the body force and the
projected fields. What the geometry decides is left to small hooks of each dimension that call
the compiled loops of :mod:`~dolfinx_sfvem.discretizations.assemble` (polygons) or
:mod:`~dolfinx_sfvem.discretizations.polyhedron_loops` (polyhedra), and to the form of a cavity's
work (:class:`EnclosedTerm`: the area enclosed by a region's boundary traces in 2D, the volume
swept by its faces in 3D).
"""
from __future__ import annotations

import abc
import dataclasses
import typing
from dataclasses import dataclass

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from dolfinx_sfvem import _compat
from dolfinx_sfvem.discretizations.compiled_energy import EnergyKernels, compile_kernels
from dolfinx_sfvem.discretizations.discretization import AssemblyInfo, Discretization, EnergyTerm, Marker
from dolfinx_sfvem.discretizations.injectivity import gather_count
from dolfinx_sfvem.discretizations.space import SFVEMNodes
from dolfinx_sfvem.physics.energy import Energy, VolumeWork


@dataclass
class Region:
    """A region's energy, or an energy term on a region (``term``), with its compiled kernels.

    Attributes
    ----------
    tag : int
    energy : Energy
    kernels : EnergyKernels
        The compiled pointwise kernels of ``energy`` in the mesh's dimension.
    cells : (n,) int64
        The region's local cells (polygons or polyhedra; indices into the space's ``cells``).
    term : EnergyTerm or None
        The energy term this record assembles; None for the region's own energy.
    """
    tag: int
    energy: Energy
    kernels: EnergyKernels
    cells: np.ndarray
    term: EnergyTerm | None = None

    @property
    def params(self) -> dict[str, float]:
        """The parameter values the loops use: the energy's, or the term's."""
        return self.energy.params if self.term is None else self.term.params

    @property
    def residual_at(self) -> tuple[int, int]:
        """Offsets of P and T in the residual kernel's output (T: -1 when absent)."""
        k = self.kernels
        assert k.residual_offsets["psi"] == 0
        return k.residual_offsets["P"], k.residual_offsets.get("T", -1)

    @property
    def tangent_at(self) -> tuple[int, int, int]:
        """Offsets of D, A and B in the tangent kernel's output (-1 when absent)."""
        k = self.kernels
        return k.tangent_offsets["D"], k.tangent_offsets.get("A", -1), k.tangent_offsets.get("B", -1)


@dataclass
class EnclosedTerm(abc.ABC):
    """The energy term −p ∫ (J − 1) dΩ of a :class:`~dolfinx_sfvem.physics.energy.VolumeWork` over a
    region, evaluated as −p times the change of the measure enclosed by the region's deformed
    boundary, exact for any nodal displacement, where the projected gradient's ∫ det Π⁰_l∇u is not.
    How the enclosed measure is computed depends on the dimension (the area inside the boundary
    traces of the polygons, the volume swept by the faces of the polyhedra): its force and its
    tangent are the subclass's.

    Attributes
    ----------
    tag : int
    energy : Energy
    cells : (n,) int64
        The region's local cells.
    term : EnergyTerm
        The energy term (its ``params["p"]`` is p).
    """
    tag: int
    energy: Energy
    cells: np.ndarray
    term: EnergyTerm

    @property
    def params(self) -> dict[str, float]:
        """The term's parameter values."""
        return self.term.params

    @abc.abstractmethod
    def add_force(self, u: np.ndarray, scale: float, R: np.ndarray) -> float:
        """R (n_local_nodes, d) += scale ∂ΔM/∂u at the nodal u (n_local_nodes, d), ΔM the change of the
        enclosed measure; returns scale ΔM (this rank's part)."""

    def add_tangent_values(self, scale: float, values: np.ndarray) -> None:
        """values += scale ∂²ΔM/∂u² in the COO order of the space's matrix, where the term is local
        to the cells (before the matrix is set; :meth:`OnSFVEMNodes.assemble_tangent`)."""

    def add_tangent_matrix(self, u: np.ndarray, scale: float, A: PETSc.Mat) -> None:
        """A += scale ∂²ΔM/∂u² at u, where the term couples through forms of its own (after the
        matrix is assembled; :meth:`OnSFVEMNodes.assemble_tangent`)."""


def _of_space(name: str) -> property:
    """A read-only member of :class:`Discretization` that is the space's attribute ``name``."""
    return property(lambda self: getattr(self.space, name), doc=f"The space's ``{name}`` (:class:`SFVEMNodes`).")


class OnSFVEMNodes(Discretization):
    """The SFVEM discretization of Σ_regions ∫ Ψ_r(F, ∇F) dΩ on the nodes of an SFVEM space,
    ``self.space`` (:class:`~dolfinx_sfvem.discretizations.space.SFVEMNodes`: polygons or polyhedra),
    in d = ``space.gdim`` dimensions (module docstring).

    Sizes, coordinates, keys, vectors, the matrix and the located nodes are the space's. A
    subclass builds its space and calls ``OnSFVEMNodes.__init__``, and supplies the hooks of its
    dimension: ``_basis_tables`` (the compiled loops' tables), ``_residual_loop``,
    ``_tangent_loop``, ``_load_loop``, ``_projected_fields``, ``_folds`` (folded and kinked
    cells, or None where the dimension has no such check) and ``_enclosed_term``.

    Parameters
    ----------
    space
        The space, with its projections and energy quadrature.
    materials
        Region tag -> energy (checked by the subclass before it builds the space).
    comm
        Communicator.
    """

    method = "vem"

    def __init__(self, space: SFVEMNodes, materials: typing.Mapping[int, Energy], comm: MPI.Comm):
        self.comm = comm
        self.materials = dict(sorted(materials.items()))
        self.space = space
        self.regions = [Region(tag, energy, compile_kernels(energy, comm, dim=space.gdim),
                               np.flatnonzero(space.tags == tag).astype(np.int64))
                        for tag, energy in self.materials.items()]
        self.terms: list[Region | EnclosedTerm] = []      # energy terms (:meth:`add_energy_term`)
        d = space.gdim
        nd = np.diff(space.dof_offsets)
        nphi = np.full(nd.size, d, dtype=np.int64)      # rows of the table: ∇φ, and ∇∇φ where Ψ uses G
        for reg in self.regions:
            nphi[reg.cells] = d + d * d if reg.kernels.uses_gradient else d
        phi_off = np.concatenate([[0], np.cumsum(nphi * nd * np.diff(space.q_offsets))]).astype(np.int64)
        self._tables = self._basis_tables(nphi, phi_off)
        self._coo_off = space.coo_offsets()
        self._values = np.zeros(self._coo_off[-1] + d * space.n_owned_nodes)     # the diagonal's entries stay 0

    # ------------------------------------------------------------------ the hooks of a dimension
    @abc.abstractmethod
    def _basis_tables(self, nphi: np.ndarray, phi_off: np.ndarray) -> typing.NamedTuple:
        """The tables of the compiled loops: every local cell's projected basis derivatives at its
        quadrature points (``nphi`` (n_local,) rows per point, cell k's at ``phi_off[k]``)."""

    @abc.abstractmethod
    def _residual_loop(self, reg: Region, c: np.ndarray, u: np.ndarray, R: np.ndarray, stats: np.ndarray) -> None:
        """R += ∂/∂ũ of the region's energy with the packed constants ``c`` at the nodal u (n_local_nodes,
        d); ``stats`` gets the energy, the smallest J and its local cell."""

    @abc.abstractmethod
    def _tangent_loop(self, reg: Region, c: np.ndarray, u: np.ndarray, values: np.ndarray) -> None:
        """The region's cell blocks of the tangent into ``values`` (COO order of the space's matrix):
        written for a region's energy, added for an energy term."""

    @abc.abstractmethod
    def _load_loop(self, f_q: np.ndarray, F: np.ndarray) -> None:
        """F (n_local_nodes, d) += ∫ f · Π^∇_2 φ dΩ from f at the energy's quadrature points f_q (n_q, d)."""

    @abc.abstractmethod
    def _projected_fields(self, u: np.ndarray, u_q: np.ndarray, grad_q: np.ndarray) -> None:
        """Π^∇_2 u into u_q (n_q, d) and Π⁰_l∇u into grad_q (n_q, d, d) at the energy's quadrature points."""

    @abc.abstractmethod
    def _folds(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """Folded and kinked masks (n_local,) of the local cells at the nodal u, or None where the
        dimension does not check its cells' boundaries (:class:`AssemblyInfo`)."""

    @abc.abstractmethod
    def _enclosed_term(self, region: Region, energy: Energy, term: EnergyTerm) -> EnclosedTerm:
        """The :class:`EnclosedTerm` of a :class:`VolumeWork` term on ``region``."""

    # ------------------------------------------------------------------ sizes and PETSc objects
    #: the members of the contract that are the space's (:class:`Discretization`)
    gdim = _of_space("gdim")
    n_owned_nodes = _of_space("n_owned_nodes")
    n_local_nodes = _of_space("n_local_nodes")
    num_dofs_global = _of_space("num_dofs_global")
    x_nodes = _of_space("x_nodes")
    node_key = _of_space("node_key")
    node_point = _of_space("node_point")
    global_nodes = _of_space("global_nodes")

    def create_vector(self) -> PETSc.Vec:
        return self.space.create_vector()

    def create_matrix(self) -> PETSc.Mat:
        """AIJ matrix with the COO pattern of the cell blocks and the owned diagonal
        (:meth:`SFVEMNodes.create_matrix`)."""
        return self.space.create_matrix()

    # ------------------------------------------------------------------ assembly
    def _internal_force(self, x: PETSc.Vec, b: PETSc.Vec, regions: typing.Sequence,
                        regularization: bool = True) -> np.ndarray:
        """b = ∂/∂ũ of the energy of ``regions`` (Eq. 52), ghosts accumulated, their regularization
        left out when ``regularization`` is False; returns this rank's [energy, min J, local cell of
        min J]."""
        stats = np.array([0.0, np.inf, -1.0])
        with x.localForm() as xl, b.localForm() as bl:
            bl.set(0.0)
            u = xl.array_r.reshape(-1, self.gdim)
            R = bl.array.reshape(-1, self.gdim)
            for reg in regions:
                self._add_force(reg, u, R, stats, regularization)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        return stats

    def _add_force(self, reg: Region | EnclosedTerm, u: np.ndarray, R: np.ndarray, stats: np.ndarray,
                   regularization: bool) -> None:
        """R += ∂/∂ũ of one region's or term's energy (Eq. 52) at the nodal u; its energy into stats[0]."""
        if isinstance(reg, EnclosedTerm):
            stats[0] += reg.add_force(u, -reg.params["p"], R)
            return
        k = reg.kernels
        self._residual_loop(reg, k.pack_constants(reg.params if regularization else reg.energy.unregularized_params()),
                            u, R, stats)

    def residual(self, x: PETSc.Vec, b: PETSc.Vec) -> AssemblyInfo:
        """Internal force b = ∂W/∂ũ (Eq. 52) at x (ghosts of x must be current), energy terms
        included, with the smallest J over all ranks and its cell, and the folded cells where the
        dimension checks them (collective)."""
        stats = self._internal_force(x, b, self.regions + self.terms)
        with x.localForm() as xl:
            folds = self._folds(xl.array_r.reshape(-1, self.gdim))
        space = self.space
        min_J, rank = self.comm.allreduce((stats[1], self.comm.rank), op=MPI.MINLOC)
        k = int(stats[2])
        where = (int(space.cells[k]), int(space.tags[k])) if k >= 0 else (-1, -1)
        cell, tag = self.comm.bcast(where, root=rank)
        info = AssemblyInfo(self.comm.allreduce(stats[0], op=MPI.SUM), float(min_J), cell, tag)
        if folds is not None:
            info.folded, info.folded_cell = gather_count(self.comm, folds[0], space.cells)
            info.kinked = gather_count(self.comm, folds[1], space.cells)[0]
        return info

    def medium_force(self, x: PETSc.Vec, b: PETSc.Vec, regularization: bool = True) -> None:
        """b = ∂W_medium/∂ũ, the internal force of the third-medium regions alone, at x; without
        their regularization when ``regularization`` is False (the same kernels, the parameters of
        :meth:`Energy.unregularized_params`)."""
        self._internal_force(x, b, [reg for reg in self.regions if reg.energy.is_medium], regularization)

    def assemble_tangent(self, x: PETSc.Vec, A: PETSc.Mat) -> None:
        """Tangent (Eq. 56) at x into A, energy terms included, constraints not applied: the cell
        blocks of the regions, then of the terms, into the COO values of A, then the terms that
        couple through forms of their own (:class:`EnclosedTerm`) into the assembled A."""
        values = self._values
        with x.localForm() as xl:
            u = xl.array_r.reshape(-1, self.gdim)
            for reg in self.regions + self.terms:
                if isinstance(reg, EnclosedTerm):
                    reg.add_tangent_values(-reg.params["p"], values)
                else:
                    self._tangent_loop(reg, reg.kernels.pack_constants(reg.params), u, values)
            _compat.mat_set_values_coo(A, values, _compat.INSERT_VALUES)
            A.assemble()
            for reg in self.terms:
                if isinstance(reg, EnclosedTerm):
                    reg.add_tangent_matrix(u, -reg.params["p"], A)

    # ------------------------------------------------------------------ energy terms
    def add_energy_term(self, tag: int, energy: Energy) -> EnergyTerm:
        """Add ∫ ψ dΩ over region ``tag`` (:meth:`Discretization.add_energy_term`). ψ must declare
        ``uses_gradient`` as the region's energy does: the term is assembled with the region's
        basis tables; a cavity's −p ∫ (J − 1) dΩ is evaluated from the region's boundary instead
        (:class:`EnclosedTerm`)."""
        region = next((reg for reg in self.regions if reg.tag == tag), None)
        if region is None:
            raise ValueError(f"energy term on region {tag}, which the mesh does not have")
        if energy.uses_gradient != region.energy.uses_gradient:
            raise ValueError(f"energy term {energy.name} on region {tag}: declare uses_gradient="
                             f"{region.energy.uses_gradient} as the region's energy {region.energy.name} does")
        term = EnergyTerm(tag, energy, dict(energy.params))
        self.terms.append(self._enclosed_term(region, energy, term) if isinstance(energy, VolumeWork) else
                          Region(region.tag, energy, compile_kernels(energy, self.comm, dim=self.gdim), region.cells,
                                 term))
        return term

    def term_force(self, term: EnergyTerm, x: PETSc.Vec, b: PETSc.Vec,
                   params: typing.Mapping[str, float] | None = None) -> float:
        """b = ∂/∂ũ ∫ ψ dΩ of the term alone (Eq. 52 over its region) with ``params``; returns ∫ ψ dΩ."""
        reg = next(reg for reg in self.terms if reg.term is term)
        alone = dataclasses.replace(reg, term=EnergyTerm(term.tag, term.energy,
                                                         dict(params if params is not None else term.params)))
        stats = self._internal_force(x, b, [alone])
        return self.comm.allreduce(float(stats[0]), op=MPI.SUM)

    # ------------------------------------------------------------------ loads and fields
    def body_force_vector(self, f: typing.Callable[[np.ndarray], np.ndarray]) -> PETSc.Vec:
        """External force vector of a body force, ∫ f · Π^∇_2 v dΩ (the b-term of Eq. 1).

        Parameters
        ----------
        f
            Body force per unit reference area (volume in 3D): ``f(x)`` with ``x`` of shape (d, n)
            returns (d, n).
        """
        x_q = self.space.x_q
        f_q = np.ascontiguousarray(np.broadcast_to(np.asarray(f(x_q.T), dtype=np.float64),
                                                   (self.gdim, x_q.shape[0])).T)
        F = self.create_vector()
        with F.localForm() as fl:
            fl.set(0.0)
            self._load_loop(f_q, fl.array.reshape(-1, self.gdim))
        F.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        return F

    def quadrature_fields(self, x: PETSc.Vec) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Points x_q (n_q, d) and weights (n_q,) of the energy quadrature with Π^∇_2 u (n_q, d) and
        Π⁰_l∇u (n_q, d, d) there (Eqs. 36, 45): the fields of :meth:`error_norms`."""
        space, d = self.space, self.gdim
        u_q, grad_q = np.empty((space.x_q.shape[0], d)), np.empty((space.x_q.shape[0], d, d))
        with x.localForm() as xl:
            self._projected_fields(xl.array_r.reshape(-1, d), u_q, grad_q)
        return space.x_q, space.w_q, u_q, grad_q

    # ------------------------------------------------------------------ unknowns and output
    def locate_nodes(self, marker: Marker | None = None, tags: typing.Iterable[int] | None = None) -> np.ndarray:
        """Local SFVEM nodes selected by ``marker`` (means at the points hosting them) and/or region
        ``tags`` (:meth:`SFVEMNodes.locate_nodes`)."""
        return self.space.locate_nodes(marker, tags)

    def output_function(self, x: PETSc.Vec, u=None):
        """The displacement as a P2 DOLFINx Function on the space's sub-mesh (:meth:`SFVEMNodes.to_function`)."""
        return self.space.to_function(x, u)

    @property
    def dolfinx_mesh(self):
        """The space's sub-mesh (sub-triangles, fan tetrahedra): the DOLFINx mesh of the output."""
        return self.space.mesh
