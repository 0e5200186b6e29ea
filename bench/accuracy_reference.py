"""The arithmetic of the equal-accuracy benchmark (``accuracy.py``): a reference value from mesh
ladders by Richardson extrapolation, with an error estimate, and the cheapest run meeting the
accuracy criteria against it. Pure Python: no solver, no files.

Richardson extrapolation of a quantity f computed on uniform meshes of sizes h_0 > h_1 > h_2 with a
constant ratio r = h_k / h_{k+1}: if f(h) = f* + C h^p + ..., the differences d_1 = f_1 - f_0 and
d_2 = f_2 - f_1 shrink by r^p, so the observed order is p = ln(d_1 / d_2) / ln r and the limit is

    f* = f_2 + d_2 / (r^p - 1).

With two levels only the order is assumed (first order: the forces of these contact problems
converge at about that rate, issue 24).
"""
from __future__ import annotations

import dataclasses
import math
import typing

#: relative tolerance on the mesh-size ratio of the levels of one extrapolation
RATIO_TOLERANCE = 1e-6


@dataclasses.dataclass(frozen=True)
class Extrapolation:
    """The limit h -> 0 of one method's ladder.

    Attributes
    ----------
    value : float
        The extrapolated value f* (or the finest level's value outside the asymptotic range).
    error : float
        Its estimated absolute error (>= 0), see :func:`richardson`.
    order : float or None
        The order p used (None: no extrapolation, the finest value).
    observed : bool
        ``order`` was observed from three levels (False: assumed).
    h : tuple of float
        Mesh sizes of the levels used, coarse to fine.
    note : str
        How the value was obtained, one sentence.
    """

    value: float
    error: float
    order: float | None
    observed: bool
    h: tuple[float, ...]
    note: str


@dataclasses.dataclass(frozen=True)
class Reference:
    """A reference value from one or more methods' extrapolations.

    Attributes
    ----------
    value : float
        Mean of the methods' extrapolated values.
    error : float
        Estimated absolute error: the largest of half the spread of the methods' values and each
        method's own error estimate.
    parts : dict method -> Extrapolation
    """

    value: float
    error: float
    parts: dict[str, Extrapolation]

    @property
    def relative_error(self) -> float:
        """``error / |value|``."""
        return self.error / abs(self.value)


def limit(h: typing.Sequence[float], f: typing.Sequence[float], order: float) -> float:
    """Richardson limit of the two finest levels with the order ``order``: f_n + d_n / (r^p - 1)."""
    r = h[-2] / h[-1]
    return f[-1] + (f[-1] - f[-2]) / (r ** order - 1.0)


def _constant_ratio(h: typing.Sequence[float]) -> bool:
    ratios = [a / b for a, b in zip(h[:-1], h[1:])]
    return all(math.isclose(q, ratios[0], rel_tol=RATIO_TOLERANCE) for q in ratios)


def observed_order(h: typing.Sequence[float], f: typing.Sequence[float]) -> float | None:
    """Order p of three levels of constant ratio whose differences shrink without changing sign
    (0 < d_2 / d_1 < 1); None otherwise (not in the asymptotic range)."""
    d1, d2 = f[1] - f[0], f[2] - f[1]
    if d1 == 0.0 or not 0.0 < d2 / d1 < 1.0:
        return None
    return math.log(d1 / d2) / math.log(h[0] / h[1])


def richardson(h: typing.Sequence[float], f: typing.Sequence[float], *, assumed_order: float = 1.0,
               alternative_order: float = 2.0) -> Extrapolation:
    """The limit of a mesh ladder and its error estimate.

    Parameters
    ----------
    h : sequence of float, length >= 2
        Mesh sizes, strictly decreasing; the finest three (or two) must have a constant ratio.
    f : sequence of float
        The quantity on each mesh.
    assumed_order
        Order expected a priori: used with two levels, and as the comparison of the observed one.
    alternative_order
        With two levels, the error estimate is the change of the limit if the order were this one.

    Returns
    -------
    Extrapolation
        Three or more levels whose finest three are in the asymptotic range
        (:func:`observed_order`): the limit with the observed order p; the error is the largest of
        the change of the limit with ``assumed_order`` instead of p and, with four or more levels,
        its change when the three levels are taken one level coarser (if those are asymptotic
        too). Three levels not in the asymptotic range: the finest value, error the larger of
        the last two differences. Two levels: the limit with ``assumed_order``, error its change
        with ``alternative_order``.

    Raises
    ------
    ValueError
        Fewer than two levels, lengths that differ, sizes not strictly decreasing, or the finest
        two or three without a constant ratio.
    """
    h, f = [float(v) for v in h], [float(v) for v in f]
    if len(h) != len(f) or len(h) < 2:
        raise ValueError(f"richardson: needs two or more levels of equal length, got {len(h)} sizes and {len(f)} values")
    if any(a <= b for a, b in zip(h[:-1], h[1:])):
        raise ValueError(f"richardson: the mesh sizes must decrease strictly, got {h}")
    if len(h) == 2:
        value = limit(h, f, assumed_order)
        return Extrapolation(value, abs(value - limit(h, f, alternative_order)), assumed_order, False, tuple(h),
                             f"two levels: order {assumed_order:g} assumed, error = change with order "
                             f"{alternative_order:g}")
    h3, f3 = h[-3:], f[-3:]
    if not _constant_ratio(h3):
        raise ValueError(f"richardson: the finest three mesh sizes {h3} have no constant ratio")
    p = observed_order(h3, f3)
    if p is None:
        d = [abs(f3[1] - f3[0]), abs(f3[2] - f3[1])]
        return Extrapolation(f3[-1], max(d), None, False, tuple(h3),
                             "three levels not in the asymptotic range (differences change sign or do not "
                             "shrink): the finest value, error = the larger of the last two differences")
    value = limit(h3, f3, p)
    error = abs(value - limit(h3, f3, assumed_order))
    note = f"three levels: observed order {p:.2f}, error = change with order {assumed_order:g}"
    if len(h) >= 4 and _constant_ratio(h[-4:-1]) and (q := observed_order(h[-4:-1], f[-4:-1])) is not None:
        error = max(error, abs(value - limit(h[-4:-1], f[-4:-1], q)))
        note += " or with the three levels one coarser"
    return Extrapolation(value, error, p, True, tuple(h3), note)


def reference(parts: typing.Mapping[str, Extrapolation]) -> Reference:
    """The mean of the methods' extrapolations; error the largest of half their spread and each
    one's own error (:class:`Reference`). ValueError without any part."""
    if not parts:
        raise ValueError("reference: no extrapolation to combine")
    values = [e.value for e in parts.values()]
    value = sum(values) / len(values)
    error = max([(max(values) - min(values)) / 2.0] + [e.error for e in parts.values()])
    return Reference(value, error, dict(parts))


# --------------------------------------------------------------------------- meeting the criteria
@dataclasses.dataclass(frozen=True)
class Outcome:
    """What one run gave, as far as the criteria are concerned.

    Attributes
    ----------
    name : str
    method : str
        ``vem`` or ``fem``.
    kind : str
        ``uniform`` or ``local`` (locally refined mesh).
    converged : bool
        The full load was reached.
    force, gap : float
        Final force and gap.
    time_s : float
        Time to the answer [s].
    """

    name: str
    method: str
    kind: str
    converged: bool
    force: float
    gap: float
    time_s: float


def relative_deviation(value: float, ref: Reference) -> float:
    """``value / ref.value - 1``."""
    return value / ref.value - 1.0


def meets(run: Outcome, force: Reference, gap: Reference, force_tolerance: float = 0.01,
          gap_tolerance: float = 0.05) -> bool:
    """Full load reached, force within ``force_tolerance`` and gap within ``gap_tolerance`` of
    the references (relative)."""
    return (run.converged and abs(relative_deviation(run.force, force)) <= force_tolerance
            and abs(relative_deviation(run.gap, gap)) <= gap_tolerance)


def cheapest(runs: typing.Iterable[Outcome], force: Reference, gap: Reference, force_tolerance: float = 0.01,
             gap_tolerance: float = 0.05) -> Outcome | None:
    """The run of least ``time_s`` among those that :func:`meets` the criteria (None if none does)."""
    good = [r for r in runs if meets(r, force, gap, force_tolerance, gap_tolerance)]
    return min(good, key=lambda r: r.time_s) if good else None
