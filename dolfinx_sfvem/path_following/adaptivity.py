"""Adaptive refinement of the third medium during a load path: indicators and limits.

After a converged load step, :meth:`ContactProblem.solve(..., adapt=Adaptivity(...))
<dolfinx_sfvem.ContactProblem.solve>` asks the indicator which polygons to split, splits them
once (:meth:`~dolfinx_sfvem.mesh.polygon_mesh.PolygonMesh.refine`; neighbours gain hanging nodes), carries the
state over (:func:`~dolfinx_sfvem.discretizations.state_transfer.transfer_state`), re-balances it at the same load and
goes on. Only third-medium polygons are split by choice (the closure of the refinement may split
a neighbour whose hanging nodes would need a too high projection order). An indicator is any
callable ``indicator(problem) -> (n_polygons,) bool`` over ``problem.mesh``, the same on every
rank, reading what :class:`ProblemState` lists (a :class:`~dolfinx_sfvem.ContactProblem` has it).
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
from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh, Refinement


class ProblemState(typing.Protocol):
    """What the indicators read of a problem at its current state."""
    mesh: PolygonMesh
    materials: typing.Mapping[int, Energy]
    disc: Discretization
    x: PETSc.Vec
    comm: MPI.Comm

    def contact_gap(self) -> Gap: ...

    def contact_pressure(self) -> ContactPressure: ...


Indicator = typing.Callable[[ProblemState], npt.NDArray[np.bool_]]


def smallest_J(problem: ProblemState) -> npt.NDArray[np.float64]:
    """min over the quadrature points of J = det(I + Π⁰_l∇u) per polygon (n_polygons,), on every
    rank (collective; SFVEM only)."""
    _, _, _, grad = problem.disc.quadrature_fields(problem.x)
    J = (1.0 + grad[:, 0, 0]) * (1.0 + grad[:, 1, 1]) - grad[:, 0, 1] * grad[:, 1, 0]
    local = np.full(problem.mesh.n_polygons, np.inf)
    np.minimum.at(local, problem.disc.quadrature_cells(), J)
    out = np.empty_like(local)
    problem.comm.Allreduce(local, out, op=MPI.MIN)
    return out


def medium_polygons(problem: ProblemState) -> npt.NDArray[np.bool_]:
    """Mask (n_polygons,) of the third-medium polygons of ``problem.mesh``."""
    medium = [tag for tag, energy in problem.materials.items() if energy.is_medium]
    return np.isin(problem.mesh.tags, medium)


@dataclass(frozen=True)
class Compression:
    """The medium polygons compressed below ``J_below``: smallest J = det F over their
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
    """The medium polygons whose reference centroid lies within ``distance`` (length unit of the
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
        ``indicator(problem)`` -> (n_polygons,) bool over ``problem.mesh``, the polygons that
        should be split at the current state (default :class:`Compression`). Only medium polygons
        of the mask are split.
    max_levels
        A polygon is split at most this many times (counted from the mesh the solve started on).
    max_unknowns
        No refinement that would give more SFVEM unknowns than this (None: no limit).
    max_l
        Closure of the refinement (:meth:`~dolfinx_sfvem.mesh.polygon_mesh.PolygonMesh.refine`).

    Attributes
    ----------
    level : (n_polygons,) int or None
        Times each polygon of the current mesh was split (None before the first use).
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

    def refinement(self, problem: ProblemState) -> Refinement | None:
        """The refinement of ``problem.mesh`` the indicator asks for at the current state within the
        limits, or None (collective: the same on every rank)."""
        mesh = problem.mesh
        if self.level is None or self.level.size != mesh.n_polygons:
            self.level = np.zeros(mesh.n_polygons, dtype=np.int64)
        wanted = np.asarray(self.indicator(problem), dtype=bool)
        if wanted.shape != (mesh.n_polygons,):
            raise ValueError(f"Adaptivity: the indicator returned shape {wanted.shape}, expected "
                             f"({mesh.n_polygons},), one flag per polygon of problem.mesh")
        chosen = wanted & medium_polygons(problem) & (self.level < self.max_levels)
        if not chosen.any():
            return None
        refinement = mesh.refine(chosen, 1, max_l=self.max_l)
        if self.max_unknowns is not None and sfvem_unknowns(refinement.mesh) > self.max_unknowns:
            return None
        return refinement

    def refined(self, refinement: Refinement) -> None:
        """Carry the levels over to the refined mesh: a child of a split polygon is one level deeper."""
        self.level = self.level[refinement.parent] + refinement.selected[refinement.parent]
