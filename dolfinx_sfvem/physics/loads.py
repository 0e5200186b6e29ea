"""Loads ramped by the load factor λ: body force, traction, pressure, point force, cavity pressure.

A :class:`Load` is what the user defines (``problem.traction(...)``, ``problem.pressure(...)``,
...): a name, where it acts and its value at λ = 1. Bound to a discretization
(:meth:`Load.bind`), it becomes a :class:`BoundLoad` that adds its nodal forces (and, where it
follows the deformation, its load stiffness) to the balance of
:class:`~dolfinx_sfvem.physics.equilibrium.Equilibrium`, and measures its magnitude and its
work-conjugate displacement per step:

================  ============================  ====================================  ==================================
load              force at λ = 1                magnitude (×λ)                        work-conjugate displacement
================  ============================  ====================================  ==================================
body force        ∫ b · v dΩ (Eq. 1)            |∫ b dΩ|                              f_b · u / |∫ b dΩ|
traction          ∫ t · v dS (dead, Eq. 1)      |t| L (resultant)                     mean u · t/|t| over the loaded edges
pressure          −p ∫ v · n da (follower)      p                                     area swept into the body
                  −p ∫ v · N dA (dead)          p                                     ∫ u · (−N) dA
point force       f at a node                   |f|                                   u · f/|f| at the node
cavity pressure   energy −p ∫ (J − 1) dΩ        p                                     ∫ (J − 1) dΩ, the cavity's area change
================  ============================  ====================================  ==================================

The boundary integrals are exact with two Gauss points per edge (:mod:`~dolfinx_sfvem.physics.edge_loads`,
docs/guide/loads.md). Each bound load acts on the elements this rank owns, so a force is counted once.
"""
from __future__ import annotations

import abc
import typing
from dataclasses import dataclass

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from dolfinx_sfvem.physics import edge_loads
from dolfinx_sfvem.physics.bound_load import BoundLoad, CavityPressureTerm, largest_entry
from dolfinx_sfvem.discretizations.discretization import Discretization, EnergyTerm
from dolfinx_sfvem.physics.energy import VolumeWork

Marker = typing.Callable[[np.ndarray], np.ndarray]
#: where a boundary load acts: a marker of points (edges whose vertices and midpoint it selects)
#: or region tags (the boundary edges of those regions)
Where = typing.Union[Marker, tuple[int, ...]]


def _describe_where(where: Where) -> typing.Any:
    return getattr(where, "__name__", "function") if callable(where) else list(where)


# --------------------------------------------------------------------------- bound loads
class VectorLoad(BoundLoad):
    """A dead load given by an assembled force vector at λ = 1 (body force, point force); its
    magnitude is ``magnitude`` and its displacement the work f · u per magnitude."""

    def __init__(self, name: str, disc: Discretization, vector: PETSc.Vec, magnitude: float):
        super().__init__(name, disc)
        self.vector = vector
        self.magnitude = magnitude
        self.reference_norm = vector.norm(PETSc.NormType.NORM_INFINITY)

    def add_force(self, u: np.ndarray | None, f: np.ndarray) -> None:
        n = self.disc.n_owned_dofs
        f.reshape(-1)[:n] += self.vector.getArray(readonly=True)

    def measure(self, x: PETSc.Vec, load: float) -> dict[str, float]:
        work = self.vector.dot(x)
        return {"magnitude": load * self.magnitude, "displacement": work / self.magnitude if self.magnitude else 0.0}


class _EdgeLoad(BoundLoad):
    """A traction or pressure on boundary edges [a, m, b] (local nodes, body on the left)."""

    def __init__(self, name: str, disc: Discretization, edges: np.ndarray):
        super().__init__(name, disc)
        self.edges = edges
        self.X = disc.x_nodes


class _BoundTraction(_EdgeLoad):
    def __init__(self, name: str, disc: Discretization, edges: np.ndarray, t: np.ndarray):
        super().__init__(name, disc, edges)
        self.t = t
        self.magnitude = self.comm.allreduce(edge_loads.traction_magnitude(edges, self.X, t), op=MPI.SUM)
        self.reference_norm = largest_entry(self, None)

    def add_force(self, u: np.ndarray | None, f: np.ndarray) -> None:
        edge_loads.dead_traction_forces(self.edges, self.X, self.t, f)

    def measure(self, x: PETSc.Vec, load: float) -> dict[str, float]:
        with x.localForm() as xl:
            local = edge_loads.traction_work(self.edges, self.X, xl.array_r.reshape(-1, 2), self.t)
        work = self.comm.allreduce(local, op=MPI.SUM)
        return {"magnitude": load * self.magnitude, "displacement": work / self.magnitude if self.magnitude else 0.0}


class _BoundPressure(_EdgeLoad):
    """A pressure; ``ends`` are the output-mesh points that end open chains of the loaded edges
    (where the follower load stiffness is not symmetric)."""

    def __init__(self, name: str, disc: Discretization, edges: np.ndarray, p: float, follower: bool,
                 ends: np.ndarray):
        super().__init__(name, disc, edges)
        self.p = p
        self.follows = self.has_stiffness = follower
        self.ends = ends
        self.reference_norm = largest_entry(self, None)

    def symmetric_with(self, constrained: np.ndarray) -> bool:
        """Whether the load stiffness is symmetric once the unknowns ``constrained`` (local mask
        (n_local_dofs,)) are eliminated: a dead pressure always; a follower one when every end
        of an open chain has a constrained component (collective)."""
        if not self.follows:
            return True
        at_ends = np.flatnonzero(np.isin(self.disc.node_point, self.ends))
        free_end = bool(np.any(~(constrained[2 * at_ends] | constrained[2 * at_ends + 1])))
        return not self.comm.allreduce(free_end, op=MPI.LOR)

    def _u(self, u: np.ndarray | None) -> np.ndarray:
        return np.zeros_like(self.X) if u is None else u

    def add_force(self, u: np.ndarray | None, f: np.ndarray) -> None:
        edge_loads.pressure_forces(self.edges, self.X, self._u(u), self.p, self.follows, f)

    def add_stiffness(self, u: np.ndarray, A: PETSc.Mat, scale: float) -> None:
        K = scale * edge_loads.pressure_stiffness(self.p)
        rows = (2 * self.disc.global_nodes[self.edges][:, :, None] + np.arange(2)).reshape(-1, 6)
        for r in rows.astype(PETSc.IntType):
            A.setValues(r, r, K, addv=PETSc.InsertMode.ADD_VALUES)

    def measure(self, x: PETSc.Vec, load: float) -> dict[str, float]:
        with x.localForm() as xl:
            u = xl.array_r.reshape(-1, 2)
            local = (edge_loads.swept_area(self.edges, self.X, u) if self.follows
                     else edge_loads.dead_pressure_conjugate(self.edges, self.X, u))
        return {"magnitude": load * self.p, "displacement": self.comm.allreduce(local, op=MPI.SUM)}


class _BoundCavityPressure(CavityPressureTerm):
    """The energy term −λ p ∫ (J − 1) dΩ over a medium region of a polygon mesh; its edges on the
    mesh boundary (``open_edges``, (n, 3) local nodes) must lie on lines x or y = const."""

    def __init__(self, name: str, disc: Discretization, term: EnergyTerm, p: float, open_edges: np.ndarray):
        super().__init__(name, disc, term, p)
        self.open_edges = open_edges

    def check_constraints(self, constrained: np.ndarray) -> None:
        """ValueError naming an edge of the region on the mesh boundary whose nodes do not all have
        the displacement normal to it (u_y on y = const, u_x on x = const) constrained."""
        component = _normal_component(self.disc.x_nodes, self.open_edges)
        free = ~constrained[2 * self.open_edges + component[:, None]].all(axis=1)
        edge = _first_edge(self.disc, self.open_edges, free)
        if edge is not None:
            text, normal = edge
            raise ValueError(f"cavity pressure {self.name!r}: region {self.term.tag} is not closed: its edge {text} "
                             f"lies on the boundary of the mesh without u_{'xy'[normal]} fixed at its nodes (a "
                             "symmetry line closes a cavity only with its normal displacement fixed)")


# --------------------------------------------------------------------------- edge selection
def boundary_edges(disc: Discretization, where: Where, name: str) -> np.ndarray:
    """The boundary edges [a, m, b] (local nodes, body on the left, (n_e, 3) int64) of the
    elements this rank owns that ``where`` selects (collective).

    Raises
    ------
    ValueError
        If the marker selects an edge that is not on the boundary of the mesh (naming it), or
        if nothing is selected.
    """
    offsets, loop, element = disc.element_loops
    mesh = disc.output_mesh
    n_sides = np.diff(offsets) // 2
    first = np.repeat(offsets[:-1], 2 * n_sides)[::2]
    k = np.arange(offsets[-1] // 2) - np.repeat(offsets[:-1] // 2, n_sides)
    a = loop[first + 2 * k]
    m = loop[first + 2 * k + 1]
    b = loop[first + (2 * k + 2) % np.repeat(2 * n_sides, n_sides)]
    edges = np.stack([a, m, b], axis=1).astype(np.int64)
    on_boundary = np.isin(mesh.edge_index(disc.node_point[a], disc.node_point[b]), mesh.boundary_edges)
    if callable(where):
        marked = np.asarray(where(disc.x_nodes.T), dtype=bool).reshape(-1)
        chosen = marked[a] & marked[m] & marked[b]
        inner = chosen & ~on_boundary
        found = [tuple(np.round(np.concatenate([disc.x_nodes[a[i]], disc.x_nodes[b[i]]]), 12) + 0.0)
                 for i in np.flatnonzero(inner)[:1]]
        found = [f for part in disc.comm.allgather(found) for f in part]
        if found:
            x0, y0, x1, y1 = found[0]
            raise ValueError(f"load {name!r}: the marker selects the edge ({x0:g}, {y0:g})-({x1:g}, {y1:g}), "
                             "which is not on the boundary of the mesh; tractions and pressures act on "
                             "boundary edges only (fill a closed cavity with third medium and use "
                             "cavity_pressure for a pressure inside the mesh)")
    else:
        tags = np.repeat(mesh.tags[element], n_sides)
        chosen = np.isin(tags, where) & on_boundary
    if disc.comm.allreduce(int(chosen.sum()), op=MPI.SUM) == 0:
        raise ValueError(f"load {name!r} selects no boundary edge")
    return edges[chosen]


def chain_ends(disc: Discretization, edges: np.ndarray) -> np.ndarray:
    """The :attr:`output_mesh` points at which the edges of all ranks form open chains (collective)."""
    pairs = np.stack([disc.node_point[edges[:, 0]], disc.node_point[edges[:, 2]]], axis=1)
    every = np.concatenate(disc.comm.allgather(pairs))
    return edge_loads.chain_ends(np.stack([every[:, 0], every[:, 0], every[:, 1]], axis=1))


# --------------------------------------------------------------------------- user-facing loads
@dataclass(frozen=True)
class Load(abc.ABC):
    """A load ramped by the load factor λ, named like a boundary condition."""
    name: str

    @abc.abstractmethod
    def bind(self, disc: Discretization, materials: typing.Mapping[int, typing.Any]) -> BoundLoad:
        """The load on ``disc`` (collective)."""

    @abc.abstractmethod
    def describe(self) -> dict[str, typing.Any]:
        """Kind and values (summary.json; a resumed run must have the same)."""


@dataclass(frozen=True)
class BodyForce(Load):
    """Body force per unit reference area (volume in 3D), ``f(x)`` (d, n) -> (d, n) (the b of Eq. 1)."""
    f: typing.Callable[[np.ndarray], np.ndarray]

    def bind(self, disc: Discretization, materials: typing.Mapping[int, typing.Any]) -> BoundLoad:
        vector = disc.body_force_vector(self.f)
        total = np.array([vector.getArray(readonly=True)[c::disc.gdim].sum() for c in range(disc.gdim)])
        resultant = float(np.linalg.norm(disc.comm.allreduce(total, op=MPI.SUM)))
        return VectorLoad(self.name, disc, vector, resultant)

    def describe(self) -> dict[str, typing.Any]:
        return {"kind": "body force", "f": getattr(self.f, "__name__", "function")}


@dataclass(frozen=True)
class Traction(Load):
    """Dead traction ``t`` (d,) per unit reference length (area in 3D) on the boundary edges
    (faces) of ``where``."""
    where: Where
    t: tuple[float, ...]

    def bind(self, disc: Discretization, materials: typing.Mapping[int, typing.Any]) -> BoundLoad:
        if disc.gdim == 3:
            from dolfinx_sfvem.physics import face_loads
            return face_loads.BoundFaceTraction(self.name, disc, face_loads.loaded_facets(disc, self.where, self.name),
                                                np.asarray(self.t, dtype=np.float64))
        return _BoundTraction(self.name, disc, boundary_edges(disc, self.where, self.name),
                              np.asarray(self.t, dtype=np.float64))

    def describe(self) -> dict[str, typing.Any]:
        return {"kind": "traction", "t": list(self.t), "where": _describe_where(self.where)}


@dataclass(frozen=True)
class Pressure(Load):
    """Pressure ``p`` on the boundary edges of ``where``, pushing into the body for p > 0: on the
    deformed boundary (``follower``, with its load stiffness) or on the reference normal."""
    where: Where
    p: float
    follower: bool = True

    def bind(self, disc: Discretization, materials: typing.Mapping[int, typing.Any]) -> BoundLoad:
        if disc.gdim == 3:
            from dolfinx_sfvem.physics import face_loads
            return face_loads.BoundFacePressure(self.name, disc, face_loads.loaded_facets(disc, self.where, self.name),
                                                float(self.p), self.follower)
        edges = boundary_edges(disc, self.where, self.name)
        return _BoundPressure(self.name, disc, edges, float(self.p), self.follower, chain_ends(disc, edges))

    def describe(self) -> dict[str, typing.Any]:
        return {"kind": "pressure", "p": self.p, "follower": self.follower, "where": _describe_where(self.where)}


@dataclass(frozen=True)
class PointForce(Load):
    """Force ``f`` (d,) at the mesh node at ``point`` (a polygon vertex or edge midpoint; in 3D any node)."""
    point: tuple[float, ...]
    f: tuple[float, ...]

    def bind(self, disc: Discretization, materials: typing.Mapping[int, typing.Any]) -> BoundLoad:
        node = point_node(disc, self.point, self.name)
        vector = disc.create_vector()
        vector.set(0.0)
        values = vector.getArray()        # on every rank: PETSc's cached norms then change on all alike
        if node is not None and node < disc.n_owned_nodes:
            values[disc.gdim * node:disc.gdim * (node + 1)] = self.f
        return VectorLoad(self.name, disc, vector, float(np.linalg.norm(self.f)))

    def describe(self) -> dict[str, typing.Any]:
        return {"kind": "point force", "point": list(self.point), "f": list(self.f)}


@dataclass(frozen=True)
class CavityPressure(Load):
    """Pressure ``p`` of a gas in a closed cavity filled with third medium (region ``tag``): the
    energy term −λ p ∫ (J − 1) dΩ over the region, the work of p on the cavity's area change.

    The region may end on the mesh boundary along symmetry lines x = const or y = const whose
    normal displacement is fixed (a half or quarter model): there the term's traction
    −p cof(F) N is normal to the line, taken by the constraint, and the region's area change is
    that of the symmetric part of the cavity."""
    tag: int
    p: float

    def bind(self, disc: Discretization, materials: typing.Mapping[int, typing.Any]) -> BoundLoad:
        energy = materials.get(self.tag)
        if energy is None or not energy.is_medium:
            raise ValueError(f"cavity pressure {self.name!r}: region {self.tag} is not a third-medium region "
                             "(fill the cavity with a ThirdMedium and give its tag)")
        if disc.gdim == 3:
            from dolfinx_sfvem.physics import face_loads
            return face_loads.bind_cavity_pressure(self.name, disc, self.tag, self.p, energy.uses_gradient)
        open_edges = np.empty((0, 3), dtype=np.int64)
        if open_boundary_edge(disc.output_mesh, self.tag) is not None:     # same answer on every rank
            open_edges = boundary_edges(disc, (self.tag,), self.name)
            skew = _first_edge(disc, open_edges, _normal_component(disc.x_nodes, open_edges) < 0)
            if skew is not None:
                raise ValueError(f"cavity pressure {self.name!r}: region {self.tag} is not closed: its edge {skew[0]} "
                                 "lies on the boundary of the mesh off the x and y directions (a cavity must be "
                                 "enclosed by other regions or by symmetry lines x = const or y = const; use "
                                 "pressure() on an open boundary)")
        term = disc.add_energy_term(self.tag, VolumeWork(p=0.0, uses_gradient=energy.uses_gradient))
        return _BoundCavityPressure(self.name, disc, term, float(self.p), open_edges)

    def describe(self) -> dict[str, typing.Any]:
        return {"kind": "cavity pressure", "region": self.tag, "p": self.p}


def open_boundary_edge(mesh, tag: int) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """The end points of an edge of region ``tag`` on the boundary of ``mesh``, or None."""
    sides = mesh.sides
    mine = (mesh.tags[sides.polygon] == tag) & (sides.neighbour < 0)
    if not mine.any():
        return None
    i = int(np.argmax(mine))
    return tuple(mesh.points[sides.start[i]]), tuple(mesh.points[sides.end[i]])


def _normal_component(X: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Per edge [a, m, b] (local nodes, coordinates X (n, 2)): the component normal to it, 1 for an
    edge along x (y = const), 0 for one along y (x = const), -1 for any other direction."""
    d = np.abs(X[edges[:, 2]] - X[edges[:, 0]])
    flat = 1e-10 * d.max(axis=1)
    return np.where(d[:, 1] <= flat, 1, np.where(d[:, 0] <= flat, 0, -1))


def _first_edge(disc: Discretization, edges: np.ndarray, chosen: np.ndarray) -> tuple[str, int] | None:
    """The first of ``edges`` with ``chosen`` over all ranks, as ``"(x0, y0)-(x1, y1)"`` and its
    :func:`_normal_component`; None if none is chosen (collective)."""
    X = disc.x_nodes
    first = edges[chosen][:1]
    size = float(np.abs(disc.output_mesh.points).max())
    shown = np.where(np.abs(X) <= 1e-12 * size, 0.0, X)     # coordinates' round-off is not shown
    found = [(f"({shown[a, 0]:g}, {shown[a, 1]:g})-({shown[b, 0]:g}, {shown[b, 1]:g})",
              int(_normal_component(X, first)[0])) for a, _, b in first]
    found = [f for part in disc.comm.allgather(found) for f in part]
    return found[0] if found else None


def point_node(disc: Discretization, point: typing.Sequence[float], name: str) -> int | None:
    """The local node at ``point`` on the rank that has it (None elsewhere; collective).

    Raises
    ------
    ValueError
        If ``point`` is not a polygon vertex or edge midpoint of the mesh, naming the nearest one.
    """
    if disc.gdim == 3:
        return _nearest_node(disc, point, name)
    mesh = disc.output_mesh
    sides = mesh.sides
    candidates = np.concatenate([mesh.points, 0.5 * (mesh.points[sides.start] + mesh.points[sides.end])])
    distance = np.linalg.norm(candidates - np.asarray(point, dtype=np.float64), axis=1)
    nearest = int(np.argmin(distance))
    scale = float(np.ptp(mesh.points, axis=0).max())
    if distance[nearest] > 1e-9 * scale:
        x, y = candidates[nearest]
        raise ValueError(f"point force {name!r}: ({point[0]:g}, {point[1]:g}) is not a node of the mesh; the "
                         f"nearest node is ({x:.10g}, {y:.10g}), {distance[nearest]:.3g} away")
    if nearest < mesh.n_points:
        key = nearest
    else:
        side = slice(nearest - mesh.n_points, nearest - mesh.n_points + 1)
        key = int(disc.midpoint_keys(sides.start[side], sides.end[side])[0])
    nodes = np.flatnonzero(disc.node_key == key)
    return int(nodes[0]) if nodes.size else None


def _nearest_node(disc: Discretization, point: typing.Sequence[float], name: str) -> int | None:
    """:func:`point_node` among the nodes of a discretization (3D: any degree-2 node)."""
    point = np.asarray(point, dtype=np.float64)
    distance = np.linalg.norm(disc.x_nodes - point, axis=1)
    local = int(np.argmin(distance)) if distance.size else -1
    nearest, rank = disc.comm.allreduce((float(distance[local]) if local >= 0 else np.inf, disc.comm.rank),
                                        op=MPI.MINLOC)
    scale = float(np.ptp(disc.output_mesh.points, axis=0).max())
    if nearest > 1e-9 * scale:
        x = disc.comm.bcast(disc.x_nodes[local] if disc.comm.rank == rank else None, root=rank)
        raise ValueError(f"point force {name!r}: {tuple(point.tolist())} is not a node of the mesh; the nearest node "
                         f"is ({', '.join(f'{c:.10g}' for c in x)}), {nearest:.3g} away")
    return local if distance.size and distance[local] <= 1e-9 * scale else None
