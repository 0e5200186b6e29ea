"""Adaptive refinement of the third medium during a load path: indicators and limits.

After a converged load step, :meth:`ContactProblem.solve(..., adapt=Adaptivity(...))
<dolfinx_sfvem.ContactProblem.solve>` asks the indicator which cells to split, splits them once
(:func:`~dolfinx_sfvem.mesh.cell_refine.refine_mesh`: polygons with hanging nodes on their
neighbours, tetrahedra by DOLFINx's conforming refinement), carries the state over
(:func:`~dolfinx_sfvem.discretizations.state_transfer.carry_state`), re-balances it at the same
load and goes on. The cells are the polygons of a 2D SFVEM problem and the tetrahedra of a 3D
FEM one: the same code for both. Only third-medium cells are split by choice (the closure of the
refinement may split a neighbour: one whose hanging nodes would need a too high projection
order, a tetrahedron the conforming refinement bisects). An indicator is any callable
``indicator(problem) -> (n_cells,) bool`` over ``problem.mesh``, the same on every rank, reading
what :class:`ProblemState` lists (a :class:`~dolfinx_sfvem.ContactProblem` has it).
docs/refinement-local.md has the measurements.
"""
from __future__ import annotations

import typing
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from petsc4py import PETSc

from dolfinx_sfvem.physics.contact import ContactPressure, Gap
from dolfinx_sfvem.discretizations.discretization import Discretization
from dolfinx_sfvem.physics.energy import Energy
from dolfinx_sfvem.discretizations.node_keys import sfvem_unknowns
from dolfinx_sfvem.mesh.cell_mesh import CellMesh
from dolfinx_sfvem.mesh.cell_refine import CellRefinement, refine_mesh
from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh, Refinement


class ProblemState(typing.Protocol):
    """What the indicators read of a problem at its current state."""
    mesh: PolygonMesh | CellMesh
    materials: typing.Mapping[int, Energy]
    disc: Discretization
    x: PETSc.Vec
    comm: MPI.Comm

    def contact_gap(self) -> Gap: ...

    def contact_pressure(self) -> ContactPressure: ...


Indicator = typing.Callable[[ProblemState], npt.NDArray[np.bool_]]


def n_cells(mesh: PolygonMesh | CellMesh) -> int:
    """The polygons of a polygon mesh, the cells of a cell mesh."""
    return int(mesh.tags.shape[0])


def unknowns(mesh: PolygonMesh | CellMesh) -> int:
    """The unknowns of the problem on ``mesh``: the SFVEM's on polygons, P2's on simplices."""
    if isinstance(mesh, CellMesh):
        return mesh.gdim * (mesh.n_points + mesh.edges().shape[0])
    return sfvem_unknowns(mesh)


def smallest_J(problem: ProblemState) -> npt.NDArray[np.float64]:
    """min over the quadrature points of J = det(I + ∇u) per cell (n_cells,), on every rank
    (collective): the SFVEM's Π⁰_l∇u over each polygon, the FEM's ∇u_h over each tetrahedron."""
    _, _, _, grad = problem.disc.quadrature_fields(problem.x)
    J = np.linalg.det(np.eye(grad.shape[1]) + grad) if grad.size else np.zeros(0)
    local = np.full(n_cells(problem.mesh), np.inf)
    np.minimum.at(local, problem.disc.quadrature_cells(), J)
    out = np.empty_like(local)
    problem.comm.Allreduce(local, out, op=MPI.MIN)
    return out


def medium_polygons(problem: ProblemState) -> npt.NDArray[np.bool_]:
    """Mask (n_cells,) of the third-medium polygons (cells) of ``problem.mesh``."""
    medium = [tag for tag, energy in problem.materials.items() if energy.is_medium]
    return np.isin(problem.mesh.tags, medium)


@dataclass(frozen=True)
class Compression:
    """The medium polygons (cells) compressed below ``J_below``: smallest J = det F over their
    quadrature points < ``J_below`` (dimensionless, in (0, 1)). The medium between two solids
    closing in on each other is what gets compressed, so this follows the contact."""
    J_below: float = 0.8

    def __post_init__(self):
        if not 0.0 < self.J_below < 1.0:
            raise ValueError(f"Compression: J_below must lie in (0, 1), got {self.J_below!r}")

    def __call__(self, problem: ProblemState) -> npt.NDArray[np.bool_]:
        return medium_polygons(problem) & (smallest_J(problem) < self.J_below)


@dataclass(frozen=True)
class NearContact:
    """The medium polygons (cells) whose reference centroid lies within ``distance`` (length unit of the
    mesh) of a node of the solids' contact zones (:class:`~dolfinx_sfvem.physics.contact.ContactPressure`:
    boundary nodes whose normal pressure exceeds the threshold fraction of their pair's largest),
    and, with ``gap_below``, only while the smallest gap is below it."""
    distance: float
    gap_below: float = np.inf

    def __post_init__(self):
        if not self.distance > 0.0:
            raise ValueError(f"NearContact: distance must be > 0, got {self.distance!r}")

    def __call__(self, problem: ProblemState) -> npt.NDArray[np.bool_]:
        gap, pressure = problem.contact_gap(), problem.contact_pressure()
        medium = medium_polygons(problem)
        if not gap.value < self.gap_below or not pressure.zone.any():
            return np.zeros_like(medium)
        centroids = problem.mesh.centroids
        zone = pressure.X[pressure.zone]
        near = np.zeros(centroids.shape[0], dtype=bool)
        for chunk in np.array_split(np.arange(centroids.shape[0]), max(1, centroids.shape[0] // 4096)):
            d2 = ((centroids[chunk, None, :] - zone[None, :, :]) ** 2).sum(axis=2)
            near[chunk] = d2.min(axis=1) <= self.distance ** 2
        return medium & near


@dataclass
class Adaptivity:
    """What to refine during a load path, and how far.

    Parameters
    ----------
    indicator
        ``indicator(problem)`` -> (n_cells,) bool over ``problem.mesh``, the polygons (tetrahedra)
        that should be split at the current state (default :class:`Compression`). Only medium
        cells of the mask are split.
    max_levels
        A cell is split at most this many times (counted from the mesh the solve started on).
    max_unknowns
        No refinement that would give more unknowns than this (None: no limit).
    max_l
        Closure of the refinement of polygons (:meth:`~dolfinx_sfvem.mesh.polygon_mesh.PolygonMesh.refine`).

    Attributes
    ----------
    level : (n_cells,) int or None
        Times each cell of the current mesh was split (None before the first use).
    """
    indicator: Indicator = field(default_factory=Compression)
    max_levels: int = 2
    max_unknowns: int | None = None
    max_l: int = 6
    level: npt.NDArray[np.int64] | None = None

    def __post_init__(self):
        if isinstance(self.max_levels, bool) or not isinstance(self.max_levels, (int, np.integer)) \
                or self.max_levels < 1:
            raise ValueError(f"Adaptivity: max_levels must be an integer >= 1, got {self.max_levels!r}")
        if self.max_unknowns is not None and not self.max_unknowns > 0:
            raise ValueError(f"Adaptivity: max_unknowns must be positive or None, got {self.max_unknowns!r}")
        if not callable(self.indicator):
            raise ValueError(f"Adaptivity: the indicator must be a function of the problem, got {self.indicator!r}")

    def refinement(self, problem: ProblemState) -> Refinement | CellRefinement | None:
        """The refinement of ``problem.mesh`` the indicator asks for at the current state within the
        limits, or None (collective: the same on every rank)."""
        mesh = problem.mesh
        n = n_cells(mesh)
        if self.level is None or self.level.size != n:
            self.level = np.zeros(n, dtype=np.int64)
        wanted = np.asarray(self.indicator(problem), dtype=bool)
        if wanted.shape != (n,):
            raise ValueError(f"Adaptivity: the indicator returned shape {wanted.shape}, expected "
                             f"({n},), one flag per polygon (cell) of problem.mesh")
        chosen = wanted & medium_polygons(problem) & (self.level < self.max_levels)
        if not chosen.any():
            return None
        refinement = refine_mesh(mesh, chosen, 1, max_l=self.max_l)
        if self.max_unknowns is not None and unknowns(refinement.mesh) > self.max_unknowns:
            return None
        return refinement

    def refined(self, refinement: Refinement | CellRefinement) -> None:
        """Carry the levels over to the refined mesh: a child of a selected cell is one level deeper."""
        self.level = self.level[refinement.parent] + refinement.selected[refinement.parent]
