"""Continuation in the third medium's gamma along the load path: a stiffer medium early, the asked one at the end.

A very weak medium (gamma = 1e-6) squeezed between two solids can make the load path stall or
end on an unstable equilibrium. With
``solve(..., gamma_start=g0)`` every :class:`~dolfinx_sfvem.physics.energy.ThirdMedium` of the problem
starts at ``g0`` and its gamma falls log-linearly with the load factor λ to the gamma it was
given at the end of the path (λ = ``until``, 1 by default)::

    gamma(λ) = g0^(1 - s) gamma^s,    s = λ / until,

so the final state is an equilibrium of the problem as given, reached along states of a stiffer
medium. A medium whose gamma is at or above ``g0`` keeps it. Every step records the gamma it
was solved with (``extra["gamma"]``, the first medium's); summary.json keeps the asked values
under ``materials`` and the schedule under ``gamma_continuation``. Needs a prescribed load factor
(:class:`~dolfinx_sfvem.path_following.stepping.LoadStepping`): under arc-length λ is an unknown and ∂R/∂λ would
miss dγ/dλ.
"""
from __future__ import annotations

import contextlib
import math
import typing

from dolfinx_sfvem.physics.energy import Energy, ThirdMedium
from dolfinx_sfvem.path_following.snes import NewtonResult
from dolfinx_sfvem.path_following.step_solver import StepSolver


class GammaContinuation:
    """The schedule of the module docstring on the third media of ``materials``.

    Parameters
    ----------
    materials
        Region tag -> energy (the problem's); its :class:`ThirdMedium` s are continued.
    start
        gamma at λ = 0, > 0.
    until
        Load factor at which every medium is back at its own gamma, in (0, 1].
    """

    def __init__(self, materials: typing.Mapping[int, Energy], start: float, until: float = 1.0):
        if not (math.isfinite(start) and start > 0.0):
            raise ValueError(f"gamma_start must be a number > 0, got {start!r}")
        self.media = {tag: e for tag, e in materials.items() if isinstance(e, ThirdMedium)}
        if not self.media:
            raise ValueError("gamma_start: the problem has no ThirdMedium region whose gamma could be continued")
        self.start, self.until = float(start), float(until)
        self.asked = {tag: e.params["gamma"] for tag, e in self.media.items()}

    def gamma(self, asked: float, load: float) -> float:
        """gamma at load factor ``load`` of a medium given ``asked``."""
        if asked >= self.start:
            return asked
        s = min(max(load / self.until, 0.0), 1.0)
        return math.exp((1.0 - s) * math.log(self.start) + s * math.log(asked))

    def set_load(self, load: float) -> None:
        """Every medium's gamma at load factor ``load``."""
        for tag, energy in self.media.items():
            energy.params["gamma"] = self.gamma(self.asked[tag], load)

    def current(self) -> float:
        """The first medium's gamma now."""
        return next(iter(self.media.values())).params["gamma"]

    @contextlib.contextmanager
    def as_asked(self) -> typing.Iterator[None]:
        """The media at the gamma they were given inside the block (the problem's identity)."""
        now = {tag: e.params["gamma"] for tag, e in self.media.items()}
        self.restore()
        try:
            yield
        finally:
            for tag, energy in self.media.items():
                energy.params["gamma"] = now[tag]

    def restore(self) -> None:
        """Every medium back at the gamma it was given."""
        for tag, energy in self.media.items():
            energy.params["gamma"] = self.asked[tag]

    def describe(self) -> dict[str, typing.Any]:
        return {"gamma_start": self.start, "until": self.until, "schedule": "log-linear in the load factor"}


class ContinuedStepSolver(StepSolver):
    """A :class:`StepSolver` (same parameters) that sets the media's gamma by ``continuation``
    for the load factor of every solve."""

    def __init__(self, *args, continuation: GammaContinuation, **kwargs):
        super().__init__(*args, **kwargs)
        self.continuation = continuation

    def solve_at(self, load: float, energy_merit: bool = False) -> NewtonResult:
        self.continuation.set_load(load)
        self.newton.forget_force()          # a force kept from another gamma is not this one's
        return super().solve_at(load, energy_merit)
