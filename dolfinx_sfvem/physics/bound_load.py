"""A load bound to one discretization (:class:`BoundLoad`): the contract between the loads of
:mod:`~dolfinx_sfvem.physics.loads` (2D edges) and :mod:`~dolfinx_sfvem.physics.face_loads`
(3D faces) and :class:`~dolfinx_sfvem.physics.equilibrium.Equilibrium`, with what both dimensions
share: the cavity pressure's energy term (:class:`CavityPressureTerm`) and the reference size of
a force (:func:`largest_entry`).
"""
from __future__ import annotations

import abc

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from dolfinx_sfvem.discretizations.discretization import Discretization, EnergyTerm


class BoundLoad(abc.ABC):
    """A load on one discretization: its nodal forces (and stiffness) in the balance, its measures.

    Attributes
    ----------
    name : str
    follows : bool
        Its force depends on the displacement (then :meth:`add_force` is called at every state).
    is_energy : bool
        It is an energy term of the discretization (then the discretization's residual and
        tangent hold it; :meth:`add_energy_force` gives its part of −∂R/∂λ).
    has_stiffness : bool
        It adds a load stiffness to the tangent (:meth:`add_stiffness`).
    reference_norm : float
        Largest entry of its force at λ = 1 in the reference state (tolerance scale).
    """

    follows = False
    is_energy = False
    has_stiffness = False
    reference_norm = 0.0

    def __init__(self, name: str, disc: Discretization):
        self.name = name
        self.disc = disc
        self.comm = disc.comm

    def set_load(self, load: float) -> None:
        """The load factor of the following evaluations."""

    def symmetric_with(self, constrained: np.ndarray) -> bool:
        """Whether its load stiffness is symmetric once the unknowns ``constrained`` (local mask
        (n_local_dofs,)) are eliminated (collective)."""
        return True

    def check_constraints(self, constrained: np.ndarray) -> None:
        """ValueError if the load needs constraints that the unknowns ``constrained`` (local mask
        (n_local_dofs,)) lack (collective)."""

    def add_force(self, u: np.ndarray | None, f: np.ndarray) -> None:
        """f += the load's nodal forces at λ = 1, at the local displacements u (n_local_nodes, d)
        (None: the reference state), into the local array f (n_local_nodes, d); only what this
        rank owns (ghost entries are accumulated by the caller)."""

    def add_stiffness(self, u: np.ndarray, A: PETSc.Mat, scale: float) -> None:
        """A += scale ∂f/∂u at u (entries added, A assembled by the caller)."""

    def add_energy_force(self, x: PETSc.Vec, f: PETSc.Vec, work: PETSc.Vec) -> None:
        """f += −∂W_c/∂u at λ = 1 (an energy load's part of −∂R/∂λ); ``work`` a scratch vector."""

    @abc.abstractmethod
    def measure(self, x: PETSc.Vec, load: float) -> dict[str, float]:
        """``{"magnitude": ..., "displacement": ...}`` at the state x and load factor ``load``
        (the table of :mod:`~dolfinx_sfvem.physics.loads`; collective)."""


class CavityPressureTerm(BoundLoad):
    """The energy term −λ p ∫ (J − 1) dΩ over a medium region (``term``, added to ``disc``'s
    energy); a subclass checks that the region is closed (:meth:`check_constraints`: its open
    boundary on symmetry lines or planes with the normal displacement fixed)."""

    is_energy = True

    def __init__(self, name: str, disc: Discretization, term: EnergyTerm, p: float):
        super().__init__(name, disc)
        self.term = term
        self.p = p
        x, work = disc.create_vector(), disc.create_vector()
        x.set(0.0)
        disc.term_force(term, x, work, {"p": p})
        self.reference_norm = work.norm(PETSc.NormType.NORM_INFINITY)
        x.destroy()
        work.destroy()

    def set_load(self, load: float) -> None:
        self.term.params["p"] = load * self.p

    def add_energy_force(self, x: PETSc.Vec, f: PETSc.Vec, work: PETSc.Vec) -> None:
        self.disc.term_force(self.term, x, work, {"p": self.p})
        f.axpy(-1.0, work)

    @abc.abstractmethod
    def check_constraints(self, constrained: np.ndarray) -> None:
        """ValueError naming a place where the region's open boundary lacks the constraint of its
        normal displacement (local mask ``constrained`` (n_local_dofs,); collective)."""

    def measure(self, x: PETSc.Vec, load: float) -> dict[str, float]:
        work = self.disc.create_vector()
        area_work = self.disc.term_force(self.term, x, work, {"p": 1.0})   # −∫ (J − 1) dΩ
        work.destroy()
        return {"magnitude": load * self.p, "displacement": -area_work}


def largest_entry(load: BoundLoad, u: np.ndarray | None) -> float:
    """Largest entry of the load's nodal forces at λ = 1 at the local displacements ``u``
    (n_local_nodes, d) (None: the reference state) over all ranks (collective)."""
    f = np.zeros((load.disc.n_local_nodes, load.disc.gdim))
    load.add_force(u, f)
    return load.comm.allreduce(float(np.abs(f).max(initial=0.0)), op=MPI.MAX)
