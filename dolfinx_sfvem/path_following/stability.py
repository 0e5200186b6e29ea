"""Whether a converged state is a stable equilibrium: the tangent's negative pivots.

Newton's method converges to any regular equilibrium, stable or not. Where the path is under
load or displacement control (:class:`~dolfinx_sfvem.path_following.stepping.LoadStepping`, the default) a
converged state whose tangent, the constraints eliminated, has negative eigenvalues is an
*unstable* equilibrium: the energy decreases along those modes (a buckled strut held straight,
a third medium squeezed under a cylinder that wants to fold). Such a state is not an answer.
The count comes from the factorization Newton made anyway: MUMPS LDLᵀ (the default linear
solver with a symmetric tangent) gives the number of negative pivots, INFOG(12), equal to the
number of negative eigenvalues by Sylvester's law of inertia
(:func:`~dolfinx_sfvem.path_following.snes.negative_pivots`; recorded per step as ``negative_pivots``, of the
tangent at the last Newton iterate, which differs from the converged state by the last update).

Under arc-length control (:class:`~dolfinx_sfvem.path_following.arclength.ArcLength`) the unstable branch
between limit points is part of the path being traced, and a negative pivot there is expected:
its controls declare ``traces_unstable_branches``. With another linear solver (LU) nothing is
known: ``stable`` is None.
"""
from __future__ import annotations

import typing


def is_stable(negative_pivots: int | None, traces_unstable_branches: bool) -> bool | None:
    """Whether a converged state with ``negative_pivots`` (None: not known) counts as stable on a
    path whose control ``traces_unstable_branches`` or not: None when the count is unknown or the
    control traces unstable branches (arc-length), else ``negative_pivots == 0``."""
    if negative_pivots is None or traces_unstable_branches:
        return None
    return negative_pivots == 0


def instability(load: float, negative_pivots: int) -> str:
    """The sentence that reports an unstable converged state at load factor ``load``."""
    s = "" if negative_pivots == 1 else "s"
    return (f"the converged state at load factor {load:.6g} is UNSTABLE: its tangent has {negative_pivots} "
            f"negative pivot{s} under load/displacement control (an equilibrium the energy leaves along "
            f"{'that mode' if negative_pivots == 1 else 'those modes'}; docs/guide/troubleshooting.md)")


def final_stability(steps: typing.Sequence[typing.Mapping[str, typing.Any]]) -> bool | None:
    """``stable`` of the last converged record of ``steps`` (None: none, or not known)."""
    last = next((s for s in reversed(steps) if s.get("converged")), None)
    return None if last is None else last.get("stable")
