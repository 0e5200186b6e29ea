"""The discrete balance with every load ramped by the load factor λ, and its derivatives.

The potential of paper Eq. 1 with the loads of :mod:`~dolfinx_sfvem.physics.loads`, discretized:

    R(u; λ) = ∂W/∂u(u) + λ Σ_c ∂W_c/∂u(u) − λ (f_b + Σ_l f_l(u)),

W the stored energy of the regions (Eq. 46), W_c the energy terms of the loads that are energies
(a cavity pressure: W_c = −p ∫ (J − 1) dΩ over its medium), f_b the body force and f_l the forces
of the boundary and point loads, dead (constant) or following the deformation (a follower
pressure). This module evaluates

- the residual R(u; λ) (constraints not applied; :meth:`Equilibrium.residual`),
- the tangent K = ∂R/∂u (:meth:`Equilibrium.tangent`): the discretization's energy Hessian plus
  the load stiffness −λ ∂f_l/∂u of the loads that follow the deformation,
- the load vector f̂ = −∂R/∂λ (:meth:`Equilibrium.load_vector`), which an arc-length control
  scales (for a dead load the force itself; for a follower load its value at the current state).

The tangent is symmetric unless a load's stiffness is not (:attr:`Equilibrium.symmetric`: a
follower pressure on an open boundary); the Newton solver then uses LU instead of LDLᵀ.
"""
from __future__ import annotations

import contextlib
import typing

from petsc4py import PETSc

from dolfinx_sfvem.discretizations.discretization import AssemblyInfo, Discretization
from dolfinx_sfvem.physics.bound_load import BoundLoad


class Equilibrium:
    """R(u; λ), ∂R/∂u and −∂R/∂λ of a discretization with its loads (module docstring).

    Parameters
    ----------
    disc
        The discretization (its energy terms registered by the loads' binding).
    loads
        The loads bound to ``disc`` (:meth:`~dolfinx_sfvem.physics.loads.Load.bind`).

    Attributes
    ----------
    load : float
        The load factor λ of the last :meth:`set_load` (0 initially).
    symmetric : bool
        Whether the tangent is symmetric with the constraints registered on ``disc`` eliminated.
    """

    def __init__(self, disc: Discretization, loads: typing.Sequence[BoundLoad] = ()):
        self.disc = disc
        self.loads = list(loads)
        names = [load.name for load in self.loads]
        if len(set(names)) != len(names):
            raise ValueError(f"two loads share a name: {names}")
        constrained = disc.constraints.mask
        for load in self.loads:
            load.check_constraints(constrained)
        self.symmetric = all([load.symmetric_with(constrained) for load in self.loads])
        self._work = disc.create_vector()
        self._dead = None                  # Σ of the dead loads' forces (assembled once)
        self._dead_norm = 0.0
        self._varying_norm = sum(load.reference_norm for load in self.loads if load.follows or load.is_energy)
        self.load = 0.0
        self.set_load(0.0)

    @property
    def has_loads(self) -> bool:
        """Whether any load is defined (else λ only scales prescribed displacements)."""
        return bool(self.loads)

    def set_load(self, load: float) -> None:
        """The load factor of the following evaluations (energy terms take their parameters)."""
        self.load = float(load)
        for bound in self.loads:
            bound.set_load(self.load)

    def _dead_force(self) -> PETSc.Vec | None:
        """Σ f_l of the dead loads (constant), assembled on first use; None without any."""
        dead = [load for load in self.loads if not load.follows and not load.is_energy]
        if self._dead is None and dead:
            self._dead = self._assemble(dead, None)
            self._dead_norm = self._dead.norm(PETSc.NormType.NORM_INFINITY)
        return self._dead

    def _assemble(self, loads: typing.Sequence[BoundLoad], x: PETSc.Vec | None, out: PETSc.Vec | None = None) -> PETSc.Vec:
        """Σ f_l(u) of ``loads`` at the state x (None: u = 0) into ``out`` (a new vector if None),
        ghost contributions accumulated on their owners."""
        f = out if out is not None else self.disc.create_vector()
        with f.localForm() as fl, (x.localForm() if x is not None else contextlib.nullcontext()) as xl:
            fl.set(0.0)
            u = None if xl is None else xl.array_r.reshape(-1, self.disc.gdim)
            for load in loads:
                load.add_force(u, fl.array.reshape(-1, self.disc.gdim))
        f.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        return f

    def _followers(self) -> list[BoundLoad]:
        return [load for load in self.loads if load.follows and not load.is_energy]

    def residual(self, x: PETSc.Vec, b: PETSc.Vec) -> AssemblyInfo:
        """R(u; λ) at x (ghosts current) into b, constraints not applied, with the state's
        diagnostics (collective)."""
        info = self.disc.residual(x, b)
        dead = self._dead_force()
        if dead is not None and self.load != 0.0:
            b.axpy(-self.load, dead)
        followers = self._followers()
        if followers and self.load != 0.0:
            b.axpy(-self.load, self._assemble(followers, x, self._work))
        return info

    @property
    def conservative(self) -> bool:
        """Whether R = ∂Π/∂u for the total potential :meth:`potential`: no load follows the
        deformation outside an energy term (a follower pressure has no potential)."""
        return not self._followers()

    def potential(self, x: PETSc.Vec) -> float:
        """Π(u; λ) = W(u) − λ f_dead · u at x (ghosts current): the stored energy with the energy
        terms' (:attr:`AssemblyInfo.energy`) minus the dead loads' work; inf where the state is
        not admissible. Meaningful when :attr:`conservative` (collective)."""
        info = self.disc.residual(x, self._work)
        if not info.admissible:
            return float("inf")
        dead = self._dead_force()
        return info.energy - (self.load * dead.dot(x) if dead is not None else 0.0)

    def tangent(self, x: PETSc.Vec, A: PETSc.Mat) -> None:
        """∂R/∂u at x into A, assembled, constraints not applied (collective)."""
        self.disc.assemble_tangent(x, A)
        stiff = [load for load in self._followers() if load.has_stiffness]
        if stiff and self.load != 0.0:
            with x.localForm() as xl:
                u = xl.array_r.reshape(-1, self.disc.gdim)
                for load in stiff:
                    load.add_stiffness(u, A, -self.load)
            A.assemble()

    def load_vector(self, x: PETSc.Vec, f: PETSc.Vec) -> None:
        """f̂ = −∂R/∂λ at x into f, constraints not applied (collective)."""
        self._assemble(self._followers(), x, f)
        dead = self._dead_force()
        if dead is not None:
            f.axpy(1.0, dead)
        for load in self.loads:
            if load.is_energy:
                load.add_energy_force(x, f, self._work)

    def external_force_norm(self) -> float:
        """|λ| times an upper bound of the external forces' largest entry at load factor 1
        (the scale of the solver's absolute tolerance; the loads that vary with u at the reference state)."""
        self._dead_force()
        return abs(self.load) * (self._dead_norm + self._varying_norm)

    def destroy(self) -> None:
        """Free the PETSc vectors."""
        self._work.destroy()
        if self._dead is not None:
            self._dead.destroy()
