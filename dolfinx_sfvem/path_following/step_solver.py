"""The equilibrium solvers of one mesh, as the controls of a load path use them.

A control (:mod:`~dolfinx_sfvem.path_following.stepping`, :mod:`~dolfinx_sfvem.path_following.arclength`) never sees the
problem: it solves through a :class:`StepSolver`, made by the load path for the problem's current
mesh. ``solve_at(λ)`` is Newton's method at a fixed load factor; :meth:`StepSolver.accept` applies
the contact honesty rule to any converged state (arc-length's too): a state whose solids overlap
is rejected like a failed solve.
"""
from __future__ import annotations

import typing

import numpy as np
from petsc4py import PETSc

from dolfinx_sfvem.physics.contact import ContactPressure, Gap
from dolfinx_sfvem.physics.equilibrium import Equilibrium
from dolfinx_sfvem.path_following.snes import NewtonResult, SNESNewton


class StepSolver:
    """The equilibrium solvers of one mesh (module docstring).

    Parameters
    ----------
    equilibrium
        R(u; λ), its tangent and load vector, loads bound to the mesh's discretization; owned
        (:meth:`destroy` frees it).
    newton
        Newton's method at a fixed load factor on ``equilibrium``; its KSP factorizes the
        tangent; owned.
    x
        The state, updated in place by the solves.
    final : (k,) array
        Values at load factor 1 of the owned constrained unknowns (the prescribed
        displacements are ``λ final``).
    dofs_of : dict
        The unknowns of every boundary condition (reactions).
    contact_state
        ``contact_state()`` -> (Gap, ContactPressure) of the current state (collective).
    tolerance
        The overlap tolerance in units of the local edge length (for the message).

    Attributes
    ----------
    contact : (Gap, ContactPressure) or None
        Of the last accepted state.
    """

    def __init__(self, equilibrium: Equilibrium, newton: SNESNewton, x: PETSc.Vec, final: np.ndarray,
                 dofs_of: typing.Mapping[str, np.ndarray],
                 contact_state: typing.Callable[[], tuple[Gap, ContactPressure]], tolerance: float):
        self.equilibrium = equilibrium
        self.newton = newton
        self.x = x
        self.final = final
        self.dofs_of = dofs_of
        self._contact_state = contact_state
        self._tolerance = tolerance
        self.contact: tuple[Gap, ContactPressure] | None = None

    def solve_at(self, load: float, energy_merit: bool = False) -> NewtonResult:
        """Newton's solve for the load factor ``load`` from :attr:`x` (constrained values
        ``load * final``), then :meth:`accept`; ``energy_merit``: its steps judged by the total
        potential while far from the solution, where there is one (:meth:`SNESNewton.solve`)."""
        return self.accept(self.newton.solve(self.x, load * self.final, load, energy_merit))

    def accept(self, result: NewtonResult) -> NewtonResult:
        """A converged state whose solids overlap is rejected (``converged`` False, ``failure``
        says where); keeps the accepted state's contact quantities (collective)."""
        if result.converged:
            self.contact = self._contact_state()
            gap = self.contact[0]
            if gap.overlapping:
                result.converged = False
                result.failure = (f"solids overlap: {gap.describe()} (more than {self._tolerance:g} times the "
                                  "local edge length)")
        return result

    def destroy(self) -> None:
        """Free the PETSc objects of the Newton solver and of the balance: the step solver owns
        both (the load path makes them for it, one per mesh)."""
        self.newton.destroy()
        self.equilibrium.destroy()
