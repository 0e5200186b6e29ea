"""Exact answers for validating loads: a plane-strain thick-walled cylinder under internal pressure.

The solid is the energy of paper Eq. 2, ``Psi = K/2 (ln J)^2 + mu/2 (J^(-2/3) tr C - 3)``, in
plane strain. A radial deformation maps the reference radius R (a <= R <= b) to the deformed
radius rho(R); its principal stretches are ``lambda_r = rho'``, ``lambda_theta = rho / R`` and
``lambda_z = 1``, so ``J = lambda_r lambda_theta`` and ``tr C = lambda_r^2 + lambda_theta^2 + 1``.

The answers, all in consistent unit-free quantities (lengths a, b; stresses K, mu, p):

* :func:`lame_cylinder`: the small-strain (Lamé) solution. The linearisation of Eq. 2 at F = I is
  ``K/2 (tr eps)^2 + mu |dev eps|^2`` (dev of the 3D strain, eps_zz = 0), i.e. isotropic with
  bulk modulus K and shear modulus mu: Lamé's first parameter is ``K - 2 mu / 3``.
* :func:`pressurized_cylinder`: the finite-strain radial solution rho(R) of the boundary value
  problem (BVP)

      (R P1)' = P2   on a < R < b,   P1 = dPsi/dlambda_r,  P2 = dPsi/dlambda_theta,
      P1(b) = 0,   P1(a) = -p rho(a)/a  (follower pressure)   or   P1(a) = -p  (dead pressure),

  the Euler-Lagrange equation of ``int_a^b Psi(rho', rho/R) R dR`` minus the work of p.
* the same with ``load = CavityMedium(gamma, mu_m, K_m)``: the hole R < a filled by a third
  medium carrying the cavity pressure, energy density ``gamma Psi_m(F) - p (J - 1)`` there
  (``Psi_m`` of paper Eq. 4, Eq. 5 when K_m = 0, plus the regularization of Eq. 3, which vanishes
  on the solution). The medium deforms homogeneously, rho = c R with c = rho(a)/a, and the
  annulus solves the same BVP with

      P1(a) = gamma dPsi_m/dlambda_r(c, c) - p c.

  Derivation: the term ``-p (J - 1)`` is a null Lagrangian (dJ/dF = cof F and Div cof F = 0), so
  inside the disc it only contributes the boundary traction ``-p cof(F) N``. For F = c I and
  G = 0 every regularization of Table 1, its derivative by F and its stress ``T = dPsi/dG``
  vanish (each Psi_r, times s(J) of Eq. 8 or not, is quadratic in G with coefficients depending
  on F), and ``P = dPsi_m/dF(c I) = dPsi_m/dlambda_r(c, c) I`` is constant: the disc is
  in equilibrium. Its first Piola stress ``(gamma dPsi_m/dlambda_r(c, c) - p c) I`` gives the
  radial traction above on R = a, where the displacements of disc and annulus agree. With
  gamma = 0 it is the follower pressure: ``-p (J - 1)`` is the exact work of p on the change of
  the cavity's area.

The BVP is solved by shooting from the free outer surface: for an outer stretch beta = rho(b)/b,
``P1(b) = 0`` gives lambda_r(b), the ODE is integrated inwards to a (``scipy.integrate.solve_ivp``,
DOP853, rtol 1e-12) and the condition at a then gives the pressure p(beta) explicitly
(:func:`cylinder_at_outer_stretch`). :func:`pressurized_cylinder` finds beta with p(beta) = p
(Brent's method on ln beta); p(beta) has a maximum, the limit pressure (:func:`limit_pressure`),
beyond which no radial solution carries a larger p. Accuracy: docs/validation-loads.md.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Literal, Union

import numpy as np
import numpy.typing as npt
import scipy.integrate
import scipy.optimize

#: relative tolerance of the ODE integration (rtol of solve_ivp)
RTOL = 1e-12


def kirchhoff_stresses(lambda_r: npt.ArrayLike, lambda_theta: npt.ArrayLike, K: float,
                       mu: float) -> tuple[np.ndarray, np.ndarray]:
    """Principal Kirchhoff stresses ``tau_i = lambda_i dPsi/dlambda_i`` of paper Eq. 2, plane strain.

    ``tau_i = K ln J + mu J^(-2/3) (lambda_i^2 - tr C / 3)``, i = r, theta, with
    ``J = lambda_r lambda_theta`` and ``tr C = lambda_r^2 + lambda_theta^2 + 1``. The first Piola
    stresses are ``P_i = tau_i / lambda_i``, the Cauchy stresses ``sigma_i = tau_i / J``.

    Parameters
    ----------
    lambda_r, lambda_theta : array_like, same shape, > 0
        Radial and hoop stretches.
    K, mu : float
        Bulk and shear modulus.

    Returns
    -------
    tau_r, tau_theta : ndarray
        Same shape as the stretches, in stress units.
    """
    lambda_r, lambda_theta = np.asarray(lambda_r, dtype=np.float64), np.asarray(lambda_theta, dtype=np.float64)
    J = lambda_r * lambda_theta
    pressure_part = K * np.log(J)
    shear = mu * J ** (-2 / 3)
    third_tr_C = (lambda_r ** 2 + lambda_theta ** 2 + 1) / 3
    return (pressure_part + shear * (lambda_r ** 2 - third_tr_C),
            pressure_part + shear * (lambda_theta ** 2 - third_tr_C))


def piola_stresses(lambda_r: npt.ArrayLike, lambda_theta: npt.ArrayLike, K: float,
                   mu: float) -> tuple[np.ndarray, np.ndarray]:
    """``P1 = dPsi/dlambda_r`` and ``P2 = dPsi/dlambda_theta`` of paper Eq. 2, plane strain (see
    :func:`kirchhoff_stresses`)."""
    tau_r, tau_theta = kirchhoff_stresses(lambda_r, lambda_theta, K, mu)
    return tau_r / lambda_r, tau_theta / lambda_theta


def _dP1(lambda_r: float, lambda_theta: float, K: float, mu: float) -> tuple[float, float]:
    """``dP1/dlambda_r`` and ``dP1/dlambda_theta`` of Eq. 2 (closed form; P1 = tau_r / lambda_r)."""
    tau_r, _ = kirchhoff_stresses(lambda_r, lambda_theta, K, mu)
    shear = mu * (lambda_r * lambda_theta) ** (-2 / 3)
    deviatoric = lambda_r ** 2 - (lambda_r ** 2 + lambda_theta ** 2 + 1) / 3
    dtau_dlambda_r = K / lambda_r + shear * (-2 / 3 * deviatoric / lambda_r + 4 / 3 * lambda_r)
    dtau_dlambda_theta = K / lambda_theta + shear * (-2 / 3 * deviatoric / lambda_theta - 2 / 3 * lambda_theta)
    return float((dtau_dlambda_r - tau_r / lambda_r) / lambda_r), float(dtau_dlambda_theta / lambda_r)


def _equilibrium(R: float, y: np.ndarray, K: float, mu: float) -> np.ndarray:
    """``(rho, lambda_r)' `` from ``(R P1)' = P2`` written as ``R dP1/dR = P2 - P1`` with
    ``dP1/dR = dP1/dlambda_r lambda_r' + dP1/dlambda_theta (lambda_r - lambda_theta) / R``."""
    rho, lambda_r = y
    lambda_theta = rho / R
    P1, P2 = piola_stresses(lambda_r, lambda_theta, K, mu)
    dP1_dlambda_r, dP1_dlambda_theta = _dP1(lambda_r, lambda_theta, K, mu)
    dlambda_r = (P2 - P1 - dP1_dlambda_theta * (lambda_r - lambda_theta)) / (R * dP1_dlambda_r)
    return np.array([lambda_r, dlambda_r])


def _radial_stretch(P1: float, lambda_theta: float, K: float, mu: float) -> float:
    """The radial stretch with ``dPsi/dlambda_r(lambda_r, lambda_theta) = P1`` (bracketed root)."""
    if not lambda_theta > 0:
        raise ValueError(f"hoop stretch must be > 0, got {lambda_theta!r}")

    def residual(lambda_r: float) -> float:
        return float(piola_stresses(lambda_r, lambda_theta, K, mu)[0]) - P1

    low, high = 0.5, 2.0
    while residual(low) > 0:  # P1 -> -inf as lambda_r -> 0
        low /= 2
    while residual(high) < 0:  # P1 -> +inf as lambda_r -> inf
        high *= 2
    return scipy.optimize.brentq(residual, low, high, xtol=1e-15, rtol=4 * np.finfo(float).eps)


def _check_geometry(a: float, b: float, K: float, mu: float) -> None:
    """ValueError naming the bad parameter of a cylinder a < R < b of moduli K, mu."""
    if not (math.isfinite(a) and a > 0):
        raise ValueError(f"inner radius a must be a number > 0, got {a!r}")
    if not (math.isfinite(b) and b > a):
        raise ValueError(f"outer radius b must be a number > a = {a!r}, got {b!r}")
    for name, value in (("K", K), ("mu", mu)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"modulus {name} must be a number > 0, got {value!r}")


@dataclasses.dataclass(frozen=True)
class LameSolution:
    """Lamé's small-strain solution of the plane-strain cylinder a < R < b under internal pressure p,
    ``u_r(R) = A R + B / R``, for the linearisation of Eq. 2 (Lamé ``lambda = K - 2 mu / 3``, shear mu).

    Attributes
    ----------
    a, b, K, mu, p : float
        Inner and outer radius, bulk and shear modulus, pressure (> 0 pushes the wall outwards).
    A, B : float
        ``A = p a^2 / (2 (lambda + mu) (b^2 - a^2))``, ``B = p a^2 b^2 / (2 mu (b^2 - a^2))``.
    """

    a: float
    b: float
    K: float
    mu: float
    p: float
    A: float
    B: float

    def u_r(self, R: npt.ArrayLike) -> np.ndarray:
        """Radial displacement at reference radii R (any shape)."""
        R = np.asarray(R, dtype=np.float64)
        return self.A * R + self.B / R

    def rho(self, R: npt.ArrayLike) -> np.ndarray:
        """Deformed radius ``R + u_r(R)``."""
        return np.asarray(R, dtype=np.float64) + self.u_r(R)

    def sigma_r(self, R: npt.ArrayLike) -> np.ndarray:
        """Radial stress ``2 (lambda + mu) A - 2 mu B / R^2``."""
        R = np.asarray(R, dtype=np.float64)
        return 2 * (self.K + self.mu / 3) * self.A - 2 * self.mu * self.B / R ** 2

    def sigma_theta(self, R: npt.ArrayLike) -> np.ndarray:
        """Hoop stress ``2 (lambda + mu) A + 2 mu B / R^2``."""
        R = np.asarray(R, dtype=np.float64)
        return 2 * (self.K + self.mu / 3) * self.A + 2 * self.mu * self.B / R ** 2

    @property
    def inner_radius_change(self) -> float:
        """``u_r(a)``."""
        return float(self.u_r(self.a))

    @property
    def cavity_area_change(self) -> float:
        """Area change of the whole cavity to first order in p, ``2 pi a u_r(a)`` (a quarter model: / 4)."""
        return 2 * math.pi * self.a * self.inner_radius_change


def lame_cylinder(a: float, b: float, K: float, mu: float, p: float) -> LameSolution:
    """Lamé's plane-strain thick-walled cylinder under internal pressure p (outer surface free).

    Parameters
    ----------
    a, b : float
        Inner and outer radius, 0 < a < b.
    K, mu : float
        Bulk and shear modulus of Eq. 2 (> 0); Lamé's first parameter is ``K - 2 mu / 3``.
    p : float
        Internal pressure (stress units).
    """
    _check_geometry(a, b, K, mu)
    lame = K - 2 * mu / 3
    wall = b ** 2 - a ** 2
    return LameSolution(a, b, K, mu, p, p * a ** 2 / (2 * (lame + mu) * wall), p * a ** 2 * b ** 2 / (2 * mu * wall))


@dataclasses.dataclass(frozen=True)
class CavityMedium:
    """A third medium filling the hole R < a and carrying the cavity pressure p: energy density
    ``gamma Psi_m(F) - p (J - 1)`` with ``Psi_m`` of paper Eq. 4 (Eq. 5 when K = 0), as
    :class:`~dolfinx_sfvem.energy.ThirdMedium` with a pressure term (module docstring).

    Attributes
    ----------
    gamma : float >= 0
        Scaling of the medium (paper Eq. 3); 0 leaves the follower pressure.
    mu, K : float >= 0
        Shear and bulk modulus of Psi_m. The regularization's weight and scaling play no part.
    """

    gamma: float
    mu: float
    K: float = 0.0

    def __post_init__(self):
        for name in ("gamma", "mu", "K"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f"CavityMedium: {name} must be a number >= 0, got {value!r}")

    def radial_piola(self, c: float, p: float) -> float:
        """``gamma dPsi_m/dlambda_r(c, c) - p c``: the disc's first Piola stress (a multiple of I)
        under the homogeneous stretch c."""
        return self.gamma * float(kirchhoff_stresses(c, c, self.K, self.mu)[0]) / c - p * c


#: what acts on the inner surface R = a: a "follower" or "dead" pressure, or a pressurized third medium
Load = Union[Literal["follower", "dead"], CavityMedium]


def _check_load(load: Load) -> None:
    if not (isinstance(load, CavityMedium) or load in ("follower", "dead")):
        raise ValueError(f"load must be 'follower', 'dead' or a CavityMedium, got {load!r}")


def _pressure(load: Load, c: float, P1: float) -> float:
    """The pressure p for which ``P1 = P1(a)`` meets the condition of ``load`` at R = a, c = rho(a)/a."""
    if load == "follower":      # P1(a) = -p c
        return -P1 / c
    if load == "dead":          # P1(a) = -p
        return -P1
    return (load.radial_piola(c, 0.0) - P1) / c   # P1(a) = gamma dPsi_m/dlambda_r(c, c) - p c


@dataclasses.dataclass(frozen=True)
class RadialSolution:
    """Finite-strain radial solution rho(R) of the pressurized cylinder (module docstring).

    Attributes
    ----------
    a, b, K, mu : float
        Inner and outer radius, bulk and shear modulus of Eq. 2.
    p : float
        The pressure.
    load : "follower", "dead" or CavityMedium
        The condition at R = a (:data:`Load`).
    c : float
        ``rho(a) / a``; with a :class:`CavityMedium` the disc R < a deforms as ``rho = c R``.
    state : callable
        ``state(R) -> (2, n)`` rows ``rho`` and ``lambda_r`` on a <= R <= b (the dense output of
        the ODE integration).
    """

    a: float
    b: float
    K: float
    mu: float
    p: float
    load: Load
    c: float
    state: Callable[[np.ndarray], np.ndarray] = dataclasses.field(repr=False)

    @property
    def filled(self) -> bool:
        """Whether the hole R < a holds a :class:`CavityMedium` (then R may be below a)."""
        return isinstance(self.load, CavityMedium)

    @property
    def medium_stress(self) -> float:
        """The Cauchy stress ``sigma_r = sigma_theta = gamma dPsi_m/dlambda_r(c, c) / c - p`` in the
        medium (NaN without one)."""
        return self.load.radial_piola(self.c, self.p) / self.c if self.filled else math.nan

    def _annulus(self, R: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Radii (flattened), their mask of R >= a, and the state there (NaN elsewhere)."""
        R = np.asarray(R, dtype=np.float64)
        lowest = 0.0 if self.filled else self.a
        slack = 1e-12 * self.b
        if R.size and (R.min() < lowest - slack or R.max() > self.b + slack):
            raise ValueError(f"reference radius R must lie in [{lowest!r}, {self.b!r}], got "
                             f"[{R.min()!r}, {R.max()!r}]")
        flat = np.clip(R.ravel(), lowest, self.b)
        wall = flat >= self.a
        rows = np.full((2, flat.size), np.nan)
        if wall.any():
            rows[:, wall] = self.state(flat[wall])
        return flat, wall, rows

    def rho(self, R: npt.ArrayLike) -> np.ndarray:
        """Deformed radius at reference radii R (any shape); ``c R`` in the medium (R < a)."""
        flat, wall, (rho, _) = self._annulus(R)
        return np.where(wall, rho, self.c * flat).reshape(np.shape(R))

    def u_r(self, R: npt.ArrayLike) -> np.ndarray:
        """Radial displacement ``rho(R) - R``."""
        return self.rho(R) - np.asarray(R, dtype=np.float64)

    def stretches(self, R: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """``lambda_r = rho'`` and ``lambda_theta = rho / R`` at R (both c in the medium)."""
        flat, wall, (rho, lambda_r) = self._annulus(R)
        with np.errstate(invalid="ignore", divide="ignore"):
            lambda_theta = rho / flat
        return (np.where(wall, lambda_r, self.c).reshape(np.shape(R)),
                np.where(wall, lambda_theta, self.c).reshape(np.shape(R)))

    def _cauchy(self, R: npt.ArrayLike, component: int) -> np.ndarray:
        lambda_r, lambda_theta = self.stretches(R)
        tau = kirchhoff_stresses(lambda_r, lambda_theta, self.K, self.mu)[component]
        in_medium = np.asarray(R, dtype=np.float64) < self.a
        return np.where(in_medium, self.medium_stress, tau / (lambda_r * lambda_theta))

    def sigma_r(self, R: npt.ArrayLike) -> np.ndarray:
        """Radial Cauchy stress ``tau_r / J`` at reference radii R."""
        return self._cauchy(R, 0)

    def sigma_theta(self, R: npt.ArrayLike) -> np.ndarray:
        """Hoop Cauchy stress ``tau_theta / J`` at reference radii R."""
        return self._cauchy(R, 1)

    @property
    def inner_radius_change(self) -> float:
        """``rho(a) - a``."""
        return (self.c - 1) * self.a

    @property
    def outer_radius_change(self) -> float:
        """``rho(b) - b``."""
        return float(self.u_r(self.b))

    @property
    def cavity_area_change(self) -> float:
        """Area change of the whole cavity ``pi (rho(a)^2 - a^2)`` (a quarter model: / 4)."""
        return math.pi * self.a ** 2 * (self.c ** 2 - 1)


def cylinder_at_outer_stretch(a: float, b: float, K: float, mu: float, outer_stretch: float,
                              load: Load = "follower") -> RadialSolution:
    """The radial solution with ``rho(b) = outer_stretch * b``, whatever pressure that takes: a point of
    the pressure-expansion path, also beyond the limit pressure (for arc-length checks).

    Parameters
    ----------
    a, b, K, mu, load
        As :func:`pressurized_cylinder`.
    outer_stretch : float > 0
        ``rho(b) / b``; above 1 for an internal pressure p > 0.
    """
    _check_geometry(a, b, K, mu)
    _check_load(load)
    if not (math.isfinite(outer_stretch) and outer_stretch > 0):
        raise ValueError(f"outer_stretch must be a number > 0, got {outer_stretch!r}")
    lambda_r = _radial_stretch(0.0, outer_stretch, K, mu)
    with np.errstate(invalid="ignore", divide="ignore"):
        ode = scipy.integrate.solve_ivp(_equilibrium, (b, a), [outer_stretch * b, lambda_r], method="DOP853",
                                        args=(K, mu), rtol=RTOL, atol=RTOL * 1e-2 * a, dense_output=True)
    rho_a, lambda_r_a = ode.y[:, -1]
    if ode.status != 0 or not (rho_a > 0 and lambda_r_a > 0):
        raise RuntimeError(f"the radial ODE from rho(b)/b = {outer_stretch!r} does not reach R = a with positive "
                           f"stretches: {ode.message}")
    c = float(rho_a / a)
    P1 = float(piola_stresses(lambda_r_a, c, K, mu)[0])
    return RadialSolution(a, b, K, mu, _pressure(load, c, P1), load, c, ode.sol)


def _walk(pressure: Callable[[float], float], t0: float, target: float) -> tuple[float, float, bool]:
    """Walk ``t = t0, 2 t0, 4 t0, ...`` (t = ln(outer stretch), p(0) = 0) until ``sign(t0) p(t)``
    reaches ``sign(t0) target`` (returns the interval holding the crossing and True) or stops growing
    (returns an interval holding the peak and False)."""
    sign = math.copysign(1.0, t0)
    ts, ps = [0.0, 0.0], [0.0, 0.0]
    t = t0
    for _ in range(64):
        ts.append(t)
        ps.append(pressure(t))
        if sign * ps[-1] >= sign * target:
            return ts[-2], ts[-1], True
        if sign * ps[-1] <= sign * ps[-2]:
            return ts[-3], ts[-1], False
        t *= 2
    raise RuntimeError(f"the pressure does not reach {target!r} up to ln(outer stretch) = {t!r}")


def _pressure_path(a: float, b: float, K: float, mu: float, load: Load) -> Callable[[float], float]:
    """The pressure p as a function of t = ln(rho(b)/b)."""
    return lambda t: cylinder_at_outer_stretch(a, b, K, mu, math.exp(t), load).p


def _peak(pressure: Callable[[float], float], low: float, high: float) -> float:
    """ln(outer stretch) of the maximum of p on [low, high] (bounded Brent)."""
    found = scipy.optimize.minimize_scalar(lambda t: -pressure(t), bounds=(low, high), method="bounded",
                                           options={"xatol": 1e-12})
    return float(found.x)


def pressurized_cylinder(a: float, b: float, K: float, mu: float, p: float,
                         load: Load = "follower") -> RadialSolution:
    """Finite-strain plane-strain cylinder a < R < b of Eq. 2 under internal pressure p.

    Parameters
    ----------
    a, b : float
        Inner and outer radius, 0 < a < b.
    K, mu : float
        Bulk and shear modulus of Eq. 2 (> 0).
    p : float
        Pressure on the inner surface (> 0 pushes it outwards), below the limit pressure
        (:func:`limit_pressure`; above it a ValueError says so).
    load : "follower", "dead" or CavityMedium
        Follower pressure, normal to and per unit of the deformed surface: ``P1(a) = -p rho(a)/a``;
        dead pressure, fixed per unit of reference surface: ``P1(a) = -p``; or a third medium in
        the hole carrying the cavity pressure: ``P1(a) = gamma dPsi_m/dlambda_r(c, c) - p c``.
    """
    _check_geometry(a, b, K, mu)
    if not math.isfinite(p):
        raise ValueError(f"pressure p must be finite, got {p!r}")
    pressure = _pressure_path(a, b, K, mu, load)
    if p == 0:
        return cylinder_at_outer_stretch(a, b, K, mu, 1.0, load)
    lame_outer = lame_cylinder(a, b, K, mu, p).u_r(b) / b
    low, high, crossed = _walk(pressure, math.copysign(max(abs(math.log1p(lame_outer)), 1e-6), p), p)
    if not crossed:
        high = _peak(pressure, min(low, high), max(low, high))
        if abs(pressure(high)) < abs(p):
            raise ValueError(f"p = {p!r} exceeds the limit pressure {pressure(high)!r} of this cylinder ({load!r} "
                             "load); cylinder_at_outer_stretch gives the path beyond it")
    t = scipy.optimize.brentq(lambda t: pressure(t) - p, low, high, xtol=1e-15, rtol=4 * np.finfo(float).eps)
    return cylinder_at_outer_stretch(a, b, K, mu, math.exp(t), load)


def limit_pressure(a: float, b: float, K: float, mu: float, load: Load = "follower") -> RadialSolution:
    """The radial solution at the largest internal pressure the cylinder carries (the maximum of p
    along the path :func:`cylinder_at_outer_stretch`; its p is the limit pressure)."""
    _check_geometry(a, b, K, mu)
    pressure = _pressure_path(a, b, K, mu, load)
    low, high, _ = _walk(pressure, 1e-2, math.inf)
    return cylinder_at_outer_stretch(a, b, K, mu, math.exp(_peak(pressure, low, high)), load)
