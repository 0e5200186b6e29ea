"""Exact answers for validating loads: a plane-strain thick-walled cylinder and a thick-walled sphere
under internal pressure, and Hertz's sphere contact.

The sphere (:func:`thick_sphere`, :func:`lame_sphere`) is the same problem with two hoop directions
(``hoop = 2``): ``lambda_theta = lambda_phi = rho / R``, ``J = lambda_r lambda_theta^2``,
``tr C = lambda_r^2 + 2 lambda_theta^2``, equilibrium ``(R^2 P_r)' = 2 R P_theta`` (P_theta per
direction), ``P_r(a) = -p (rho(a)/a)^2`` (follower) or ``-p`` (dead), ``P_r(b) = 0``; everything
below holds with these replacements (``c^hoop`` for c where the area of the inner surface enters).
:func:`hertz_sphere` gives Hertz's contact radius, peak pressure and indentation.

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
from typing import Literal, NamedTuple, Union

import numpy as np
import numpy.typing as npt
import scipy.integrate
import scipy.optimize

#: relative tolerance of the ODE integration (rtol of solve_ivp)
RTOL = 1e-12


def kirchhoff_stresses(lambda_r: npt.ArrayLike, lambda_theta: npt.ArrayLike, K: float,
                       mu: float, hoop: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Principal Kirchhoff stresses ``tau_i = lambda_i dPsi/dlambda_i`` of paper Eq. 2 under a radial
    deformation: plane strain (``hoop = 1``, the cylinder) or spherical (``hoop = 2``).

    ``tau_i = K ln J + mu J^(-2/3) (lambda_i^2 - tr C / 3)``, i = r, theta, with
    ``J = lambda_r lambda_theta^hoop`` and ``tr C = lambda_r^2 + hoop lambda_theta^2 + 2 - hoop``
    (the cylinder's lambda_z = 1). The first Piola stresses are ``P_i = tau_i / lambda_i`` (the hoop
    one per hoop direction), the Cauchy stresses ``sigma_i = tau_i / J``.

    Parameters
    ----------
    lambda_r, lambda_theta : array_like, same shape, > 0
        Radial and hoop stretches.
    K, mu : float
        Bulk and shear modulus.
    hoop : 1 or 2
        Number of hoop directions: 1 for the cylinder in plane strain, 2 for the sphere.

    Returns
    -------
    tau_r, tau_theta : ndarray
        Same shape as the stretches, in stress units.
    """
    lambda_r, lambda_theta = np.asarray(lambda_r, dtype=np.float64), np.asarray(lambda_theta, dtype=np.float64)
    J = lambda_r * lambda_theta ** hoop
    pressure_part = K * np.log(J)
    shear = mu * J ** (-2 / 3)
    third_tr_C = (lambda_r ** 2 + hoop * lambda_theta ** 2 + 2 - hoop) / 3
    return (pressure_part + shear * (lambda_r ** 2 - third_tr_C),
            pressure_part + shear * (lambda_theta ** 2 - third_tr_C))


def piola_stresses(lambda_r: npt.ArrayLike, lambda_theta: npt.ArrayLike, K: float,
                   mu: float, hoop: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """``P1 = dPsi/dlambda_r`` and ``P2 = (1/hoop) dPsi/dlambda_theta`` (per hoop direction) of paper
    Eq. 2 under a radial deformation (see :func:`kirchhoff_stresses`)."""
    tau_r, tau_theta = kirchhoff_stresses(lambda_r, lambda_theta, K, mu, hoop)
    return tau_r / lambda_r, tau_theta / lambda_theta


def _dP1(lambda_r: float, lambda_theta: float, K: float, mu: float, hoop: int) -> tuple[float, float]:
    """``dP1/dlambda_r`` and ``dP1/dlambda_theta`` of Eq. 2 (closed form; P1 = tau_r / lambda_r)."""
    tau_r, _ = kirchhoff_stresses(lambda_r, lambda_theta, K, mu, hoop)
    shear = mu * (lambda_r * lambda_theta ** hoop) ** (-2 / 3)
    deviatoric = lambda_r ** 2 - (lambda_r ** 2 + hoop * lambda_theta ** 2 + 2 - hoop) / 3
    dtau_dlambda_r = K / lambda_r + shear * (-2 / 3 * deviatoric / lambda_r + 4 / 3 * lambda_r)
    dtau_dlambda_theta = hoop * (K / lambda_theta
                                 + shear * (-2 / 3 * deviatoric / lambda_theta - 2 / 3 * lambda_theta))
    return float((dtau_dlambda_r - tau_r / lambda_r) / lambda_r), float(dtau_dlambda_theta / lambda_r)


def _equilibrium(R: float, y: np.ndarray, K: float, mu: float, hoop: int) -> np.ndarray:
    """``(rho, lambda_r)' `` from ``(R^hoop P1)' = hoop R^(hoop-1) P2`` written as
    ``R dP1/dR = hoop (P2 - P1)`` with
    ``dP1/dR = dP1/dlambda_r lambda_r' + dP1/dlambda_theta (lambda_r - lambda_theta) / R``."""
    rho, lambda_r = y
    lambda_theta = rho / R
    P1, P2 = piola_stresses(lambda_r, lambda_theta, K, mu, hoop)
    dP1_dlambda_r, dP1_dlambda_theta = _dP1(lambda_r, lambda_theta, K, mu, hoop)
    dlambda_r = (hoop * (P2 - P1) - dP1_dlambda_theta * (lambda_r - lambda_theta)) / (R * dP1_dlambda_r)
    return np.array([lambda_r, dlambda_r])


def _radial_stretch(P1: float, lambda_theta: float, K: float, mu: float, hoop: int) -> float:
    """The radial stretch with ``dPsi/dlambda_r(lambda_r, lambda_theta) = P1`` (bracketed root)."""
    if not lambda_theta > 0:
        raise ValueError(f"hoop stretch must be > 0, got {lambda_theta!r}")

    def residual(lambda_r: float) -> float:
        return float(piola_stresses(lambda_r, lambda_theta, K, mu, hoop)[0]) - P1

    low, high = 0.5, 2.0
    while residual(low) > 0:  # P1 -> -inf as lambda_r -> 0
        low /= 2
    while residual(high) < 0:  # P1 -> +inf as lambda_r -> inf
        high *= 2
    return scipy.optimize.brentq(residual, low, high, xtol=1e-15, rtol=4 * np.finfo(float).eps)


def _check_geometry(a: float, b: float, K: float, mu: float) -> None:
    """ValueError naming the bad parameter of a cylinder or sphere a < R < b of moduli K, mu."""
    if not (math.isfinite(a) and a > 0):
        raise ValueError(f"inner radius a must be a number > 0, got {a!r}")
    if not (math.isfinite(b) and b > a):
        raise ValueError(f"outer radius b must be a number > a = {a!r}, got {b!r}")
    for name, value in (("K", K), ("mu", mu)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"modulus {name} must be a number > 0, got {value!r}")


#: the whole cavity's measure is CAVITY_MEASURE[hoop] a^(hoop + 1): the disc's area, the ball's volume
_CAVITY_MEASURE = {1: math.pi, 2: 4 * math.pi / 3}

#: what a cavity's measure is, by the number of hoop directions
_CAVITY_KIND = {1: "area (cylinder)", 2: "volume (sphere)"}


class _Cavity:
    """The cavity's area (cylinder) or volume (sphere) change, from ``hoop`` and ``_cavity_change()``."""

    hoop: int

    def _cavity_change(self) -> float:
        raise NotImplementedError

    def _checked(self, hoop: int) -> float:
        if self.hoop != hoop:
            raise AttributeError(f"the cavity change here is its {_CAVITY_KIND[self.hoop]}, not its "
                                 f"{_CAVITY_KIND[hoop]}")
        return self._cavity_change()

    @property
    def cavity_area_change(self) -> float:
        """Area change of the cylinder's whole cavity (a quarter model: / 4)."""
        return self._checked(1)

    @property
    def cavity_volume_change(self) -> float:
        """Volume change of the sphere's whole cavity (a 1/8 model: / 8)."""
        return self._checked(2)


@dataclasses.dataclass(frozen=True)
class LameSolution(_Cavity):
    """Lamé's small-strain solution of the thick-walled cylinder (plane strain, ``hoop = 1``) or
    sphere (``hoop = 2``) a < R < b under internal pressure p, ``u_r(R) = A R + B / R^hoop``, for the
    linearisation of Eq. 2 (Lamé ``lambda = K - 2 mu / 3``, shear mu).

    Attributes
    ----------
    a, b, K, mu, p : float
        Inner and outer radius, bulk and shear modulus, pressure (> 0 pushes the wall outwards).
    A, B : float
        ``A = p a^(m+1) / (((m+1) lambda + 2 mu) (b^(m+1) - a^(m+1)))`` and
        ``B = p a^(m+1) b^(m+1) / (2 m mu (b^(m+1) - a^(m+1)))``, m = hoop: for the cylinder
        ``A = p a^2 / (2 (lambda + mu) (b^2 - a^2))``, ``B = p a^2 b^2 / (2 mu (b^2 - a^2))``; for the
        sphere ``A = p a^3 / (3 K (b^3 - a^3))``, ``B = p a^3 b^3 / (4 mu (b^3 - a^3))``, i.e.
        ``u(r) = p a^3 / (E (b^3 - a^3)) [(1 - 2 nu) r + (1 + nu) b^3 / (2 r^2)]``.
    hoop : 1 or 2
        Cylinder or sphere.
    """

    a: float
    b: float
    K: float
    mu: float
    p: float
    A: float
    B: float
    hoop: int = 1

    def u_r(self, R: npt.ArrayLike) -> np.ndarray:
        """Radial displacement at reference radii R (any shape)."""
        R = np.asarray(R, dtype=np.float64)
        return self.A * R + self.B / R ** self.hoop

    def rho(self, R: npt.ArrayLike) -> np.ndarray:
        """Deformed radius ``R + u_r(R)``."""
        return np.asarray(R, dtype=np.float64) + self.u_r(R)

    def stretches(self, R: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """``lambda_r = 1 + u_r'`` and ``lambda_theta = 1 + u_r / R`` at reference radii R (any shape):
        ``1 + A - m B / R^(m+1)`` and ``1 + A + B / R^(m+1)`` (m = hoop)."""
        R = np.asarray(R, dtype=np.float64)
        tail = self.B / R ** (self.hoop + 1)
        return 1 + self.A - self.hoop * tail, 1 + self.A + tail

    @property
    def _volumetric(self) -> float:
        """``(m + 1) lambda + 2 mu``: the radial stress per unit of A."""
        return (1 + self.hoop) * self.K + 2 * self.mu * (2 - self.hoop) / 3

    def sigma_r(self, R: npt.ArrayLike) -> np.ndarray:
        """Radial stress ``((m + 1) lambda + 2 mu) A - 2 m mu B / R^(m+1)`` (m = hoop)."""
        R = np.asarray(R, dtype=np.float64)
        return self._volumetric * self.A - 2 * self.hoop * self.mu * self.B / R ** (self.hoop + 1)

    def sigma_theta(self, R: npt.ArrayLike) -> np.ndarray:
        """Hoop stress ``((m + 1) lambda + 2 mu) A + 2 mu B / R^(m+1)`` (m = hoop)."""
        R = np.asarray(R, dtype=np.float64)
        return self._volumetric * self.A + 2 * self.mu * self.B / R ** (self.hoop + 1)

    @property
    def inner_radius_change(self) -> float:
        """``u_r(a)``."""
        return float(self.u_r(self.a))

    @property
    def outer_radius_change(self) -> float:
        """``u_r(b)``."""
        return float(self.u_r(self.b))

    def _cavity_change(self) -> float:
        """To first order in p: ``2 pi a u_r(a)`` (cylinder), ``4 pi a^2 u_r(a)`` (sphere)."""
        return (self.hoop + 1) * _CAVITY_MEASURE[self.hoop] * self.a ** self.hoop * self.inner_radius_change


def radial_field(solution: LameSolution | RadialSolution
                 ) -> tuple[Callable[[np.ndarray], np.ndarray], Callable[[np.ndarray], np.ndarray]]:
    """The displacement of a radial ``solution`` in Cartesian components about the origin, for
    :meth:`~dolfinx_sfvem.discretizations.discretization.Discretization.error_norms`:
    ``u = (lambda_theta - 1) X`` and ``grad u = (lambda_theta - 1) I + (lambda_r - lambda_theta) e_r e_r``
    (e_r = X / R), with the solution's :meth:`~RadialSolution.stretches` at R = ``|X|`` clipped to
    [a, b] ([0, b] with a medium filling R < a): a discrete wall reaches a little beyond the exact
    one (flat faces' chords inside R = a, curved faces' O(h^3) bulges), where the stretches of the
    nearest radius extend u continuously.

    Parameters
    ----------
    solution
        The cylinder's (``hoop = 1``: points in the plane, d = 2) or the sphere's (``hoop = 2``:
        d = 3), Lamé's or the finite-strain one.

    Returns
    -------
    u_exact, grad_exact
        ``u_exact(X)`` (d, n) and ``grad_exact(X)`` (d, d, n) for reference points X (d, n), R > 0.
    """
    d = solution.hoop + 1
    lowest = 0.0 if getattr(solution, "filled", False) else solution.a

    def u_exact(X: np.ndarray) -> np.ndarray:
        X = np.asarray(X, dtype=np.float64)[:d]
        _, lambda_theta = solution.stretches(np.clip(np.linalg.norm(X, axis=0), lowest, solution.b))
        return (lambda_theta - 1) * X

    def grad_exact(X: np.ndarray) -> np.ndarray:
        X = np.asarray(X, dtype=np.float64)[:d]
        R = np.linalg.norm(X, axis=0)
        lambda_r, lambda_theta = solution.stretches(np.clip(R, lowest, solution.b))
        e_r = X / R
        return (lambda_theta - 1) * np.eye(d)[:, :, None] + (lambda_r - lambda_theta) * e_r[:, None] * e_r[None]
    return u_exact, grad_exact


def _lame(a: float, b: float, K: float, mu: float, p: float, hoop: int) -> LameSolution:
    _check_geometry(a, b, K, mu)
    lame = K - 2 * mu / 3
    m = hoop
    wall = b ** (m + 1) - a ** (m + 1)
    return LameSolution(a, b, K, mu, p, p * a ** (m + 1) / (((m + 1) * lame + 2 * mu) * wall),
                        p * a ** (m + 1) * b ** (m + 1) / (2 * m * mu * wall), hoop)


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
    return _lame(a, b, K, mu, p, 1)


def lame_sphere(a: float, b: float, K: float, mu: float, p: float) -> LameSolution:
    """Lamé's thick-walled sphere under internal pressure p (outer surface free), arguments as
    :func:`lame_cylinder`: ``u(r) = p a^3 / (E (b^3 - a^3)) [(1 - 2 nu) r + (1 + nu) b^3 / (2 r^2)]``
    with ``E = 9 K mu / (3 K + mu)``, ``nu = (3 K - 2 mu) / (2 (3 K + mu))``."""
    return _lame(a, b, K, mu, p, 2)


@dataclasses.dataclass(frozen=True)
class CavityMedium:
    """A third medium filling the hole R < a and carrying the cavity pressure p: energy density
    ``gamma Psi_m(F) - p (J - 1)`` with ``Psi_m`` of paper Eq. 4 (Eq. 5 when K = 0), as
    :class:`~dolfinx_sfvem.physics.energy.ThirdMedium` with a pressure term (module docstring).

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

    def radial_piola(self, c: float, p: float, hoop: int = 1) -> float:
        """``gamma dPsi_m/dlambda_r(c, c) - p c^hoop``: the medium's first Piola stress (a multiple of
        I) under the homogeneous stretch c (``hoop``: 1 disc in plane strain, 2 ball)."""
        return self.gamma * float(kirchhoff_stresses(c, c, self.K, self.mu, hoop)[0]) / c - p * c ** hoop


#: what acts on the inner surface R = a: a "follower" or "dead" pressure, or a pressurized third medium
Load = Union[Literal["follower", "dead"], CavityMedium]


def _check_load(load: Load) -> None:
    if not (isinstance(load, CavityMedium) or load in ("follower", "dead")):
        raise ValueError(f"load must be 'follower', 'dead' or a CavityMedium, got {load!r}")


def _pressure(load: Load, c: float, P1: float, hoop: int) -> float:
    """The pressure p for which ``P1 = P1(a)`` meets the condition of ``load`` at R = a, c = rho(a)/a."""
    if load == "follower":      # P1(a) = -p c^hoop
        return -P1 / c ** hoop
    if load == "dead":          # P1(a) = -p
        return -P1
    return (load.radial_piola(c, 0.0, hoop) - P1) / c ** hoop   # P1(a) = gamma dPsi_m/dlambda_r(c, c) - p c^hoop


@dataclasses.dataclass(frozen=True)
class RadialSolution(_Cavity):
    """Finite-strain radial solution rho(R) of the pressurized cylinder (``hoop = 1``) or sphere
    (``hoop = 2``) (module docstring).

    Attributes
    ----------
    a, b, K, mu : float
        Inner and outer radius, bulk and shear modulus of Eq. 2.
    p : float
        The pressure.
    load : "follower", "dead" or CavityMedium
        The condition at R = a (:data:`Load`).
    c : float
        ``rho(a) / a``; with a :class:`CavityMedium` the hole R < a deforms as ``rho = c R``.
    state : callable
        ``state(R) -> (2, n)`` rows ``rho`` and ``lambda_r`` on a <= R <= b (the dense output of
        the ODE integration).
    hoop : 1 or 2
        Cylinder (plane strain) or sphere.
    """

    a: float
    b: float
    K: float
    mu: float
    p: float
    load: Load
    c: float
    state: Callable[[np.ndarray], np.ndarray] = dataclasses.field(repr=False)
    hoop: int = 1

    @property
    def filled(self) -> bool:
        """Whether the hole R < a holds a :class:`CavityMedium` (then R may be below a)."""
        return isinstance(self.load, CavityMedium)

    @property
    def lame(self) -> LameSolution:
        """Lamé's small-strain solution at the same pressure (the limit of this one as p -> 0)."""
        return _lame(self.a, self.b, self.K, self.mu, self.p, self.hoop)

    @property
    def medium_stress(self) -> float:
        """The Cauchy stress ``sigma_r = sigma_theta = (gamma dPsi_m/dlambda_r(c, c) - p c^hoop) / c^hoop``
        in the medium (NaN without one)."""
        return self.load.radial_piola(self.c, self.p, self.hoop) / self.c ** self.hoop if self.filled else math.nan

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
        tau = kirchhoff_stresses(lambda_r, lambda_theta, self.K, self.mu, self.hoop)[component]
        in_medium = np.asarray(R, dtype=np.float64) < self.a
        return np.where(in_medium, self.medium_stress, tau / (lambda_r * lambda_theta ** self.hoop))

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

    def _cavity_change(self) -> float:
        """``pi (rho(a)^2 - a^2)`` (cylinder) or ``4/3 pi (rho(a)^3 - a^3)`` (sphere)."""
        return _CAVITY_MEASURE[self.hoop] * self.a ** (self.hoop + 1) * (self.c ** (self.hoop + 1) - 1)


def _at_outer_stretch(a: float, b: float, K: float, mu: float, outer_stretch: float, load: Load,
                      hoop: int) -> RadialSolution:
    """The radial solution with ``rho(b) = outer_stretch * b`` (see :func:`cylinder_at_outer_stretch`)."""
    _check_geometry(a, b, K, mu)
    _check_load(load)
    if not (math.isfinite(outer_stretch) and outer_stretch > 0):
        raise ValueError(f"outer_stretch must be a number > 0, got {outer_stretch!r}")
    lambda_r = _radial_stretch(0.0, outer_stretch, K, mu, hoop)
    with np.errstate(invalid="ignore", divide="ignore"):
        ode = scipy.integrate.solve_ivp(_equilibrium, (b, a), [outer_stretch * b, lambda_r], method="DOP853",
                                        args=(K, mu, hoop), rtol=RTOL, atol=RTOL * 1e-2 * a, dense_output=True)
    rho_a, lambda_r_a = ode.y[:, -1]
    if ode.status != 0 or not (rho_a > 0 and lambda_r_a > 0):
        raise RuntimeError(f"the radial ODE from rho(b)/b = {outer_stretch!r} does not reach R = a with positive "
                           f"stretches: {ode.message}")
    c = float(rho_a / a)
    P1 = float(piola_stresses(lambda_r_a, c, K, mu, hoop)[0])
    return RadialSolution(a, b, K, mu, _pressure(load, c, P1, hoop), load, c, ode.sol, hoop)


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
    return _at_outer_stretch(a, b, K, mu, outer_stretch, load, 1)


def sphere_at_outer_stretch(a: float, b: float, K: float, mu: float, outer_stretch: float,
                            load: Load = "follower") -> RadialSolution:
    """:func:`cylinder_at_outer_stretch` for the thick sphere (:func:`thick_sphere`)."""
    return _at_outer_stretch(a, b, K, mu, outer_stretch, load, 2)


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


def _pressure_path(a: float, b: float, K: float, mu: float, load: Load, hoop: int) -> Callable[[float], float]:
    """The pressure p as a function of t = ln(rho(b)/b)."""
    return lambda t: _at_outer_stretch(a, b, K, mu, math.exp(t), load, hoop).p


def _peak(pressure: Callable[[float], float], low: float, high: float) -> float:
    """ln(outer stretch) of the maximum of p on [low, high] (bounded Brent)."""
    found = scipy.optimize.minimize_scalar(lambda t: -pressure(t), bounds=(low, high), method="bounded",
                                           options={"xatol": 1e-12})
    return float(found.x)


def _pressurized(a: float, b: float, K: float, mu: float, p: float, load: Load, hoop: int) -> RadialSolution:
    """The radial solution under the pressure p (see :func:`pressurized_cylinder`)."""
    _check_geometry(a, b, K, mu)
    if not math.isfinite(p):
        raise ValueError(f"pressure p must be finite, got {p!r}")
    pressure = _pressure_path(a, b, K, mu, load, hoop)
    if p == 0:
        return _at_outer_stretch(a, b, K, mu, 1.0, load, hoop)
    lame_outer = _lame(a, b, K, mu, p, hoop).u_r(b) / b
    low, high, crossed = _walk(pressure, math.copysign(max(abs(math.log1p(lame_outer)), 1e-6), p), p)
    if not crossed:
        high = _peak(pressure, min(low, high), max(low, high))
        if abs(pressure(high)) < abs(p):
            raise ValueError(f"p = {p!r} exceeds the limit pressure {pressure(high)!r} of this "
                             f"{'cylinder' if hoop == 1 else 'sphere'} ({load!r} load); "
                             f"{'cylinder' if hoop == 1 else 'sphere'}_at_outer_stretch gives the path beyond it")
    t = scipy.optimize.brentq(lambda t: pressure(t) - p, low, high, xtol=1e-15, rtol=4 * np.finfo(float).eps)
    return _at_outer_stretch(a, b, K, mu, math.exp(t), load, hoop)


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
    return _pressurized(a, b, K, mu, p, load, 1)


def thick_sphere(a: float, b: float, K: float, mu: float, p: float, follower: bool = True, *,
                 medium: CavityMedium | None = None) -> RadialSolution:
    """Finite-strain thick-walled sphere a < R < b of Eq. 2 (3D) under internal pressure p: the radial
    solution of ``(R^2 P_r)' = 2 R P_theta`` with ``P_r(b) = 0`` and at R = a

    * follower pressure (``follower=True``), on the deformed area: ``P_r(a) = -p (rho(a)/a)^2``;
    * dead pressure (``follower=False``), per unit of reference area: ``P_r(a) = -p``;
    * with ``medium``, a third medium filling the ball R < a and carrying the cavity pressure p
      (energy ``gamma Psi_m - p (J - 1)``, deforming homogeneously):
      ``P_r(a) = gamma dPsi_m/dlambda_r(c, c, c) - p c^2``, c = rho(a)/a.

    Its ``lame`` is Lamé's small-strain solution at the same p (:func:`lame_sphere`); ``u_r(R)``,
    ``inner_radius_change`` u_r(a), ``outer_radius_change`` u_r(b), ``cavity_volume_change``
    ``4/3 pi (rho(a)^3 - a^3)`` (the whole sphere's; a 1/8 model: / 8), ``stretches``, ``sigma_r`` and
    ``sigma_theta`` give the fields. Above the limit pressure (p(rho(b)) has a maximum) a ValueError
    says so; :func:`sphere_at_outer_stretch` gives the path beyond.

    Parameters
    ----------
    a, b, K, mu, p : float
        Radii 0 < a < b, moduli of Eq. 2 and the pressure, as :func:`pressurized_cylinder`.
    follower : bool
        Follower (True) or dead (False) pressure; ignored with ``medium``.
    medium : CavityMedium, optional
        The third medium in the cavity.
    """
    load: Load = medium if medium is not None else ("follower" if follower else "dead")
    return _pressurized(a, b, K, mu, p, load, 2)


def limit_pressure(a: float, b: float, K: float, mu: float, load: Load = "follower") -> RadialSolution:
    """The radial solution at the largest internal pressure the cylinder carries (the maximum of p
    along the path :func:`cylinder_at_outer_stretch`; its p is the limit pressure)."""
    _check_geometry(a, b, K, mu)
    pressure = _pressure_path(a, b, K, mu, load, 1)
    low, high, _ = _walk(pressure, 1e-2, math.inf)
    return _at_outer_stretch(a, b, K, mu, math.exp(_peak(pressure, low, high)), load, 1)


class HertzContact(NamedTuple):
    """Hertz's elastic sphere-on-body contact (:func:`hertz_sphere`).

    Attributes
    ----------
    a : float
        Contact radius ``(3 F R / (4 E*))^(1/3)``.
    p0 : float
        Peak pressure ``3 F / (2 pi a^2)`` (the pressure is ``p0 sqrt(1 - r^2 / a^2)``).
    delta : float
        Indentation (approach of the two bodies' far points) ``a^2 / R``.
    E_star : float
        Contact modulus, ``1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2``.
    """

    a: float
    p0: float
    delta: float
    E_star: float


def hertz_sphere(F: float, R: float, E1: float, nu1: float, E2: float = math.inf, nu2: float = 0.0) -> HertzContact:
    """Hertz's contact of a sphere of radius R (E2, nu2) pressed by the force F into a flat elastic
    half-space (E1, nu1) (small strain, frictionless; E2 = inf: a rigid sphere).

    F is the whole sphere's force: a quarter model carries F / 4. A body of E, nu given by the bulk and
    shear modulus of Eq. 2 has ``E = 9 K mu / (3 K + mu)``, ``nu = (3 K - 2 mu) / (2 (3 K + mu))``.
    """
    for name, value in (("F", F), ("R", R), ("E1", E1), ("E2", E2)):
        if not (value > 0):
            raise ValueError(f"hertz_sphere: {name} must be > 0, got {value!r}")
    for name, value in (("nu1", nu1), ("nu2", nu2)):
        if not (-1.0 < value <= 0.5):
            raise ValueError(f"hertz_sphere: Poisson's ratio {name} must lie in (-1, 0.5], got {value!r}")
    E_star = 1.0 / ((1 - nu1 ** 2) / E1 + (1 - nu2 ** 2) / E2)
    a = (3 * F * R / (4 * E_star)) ** (1 / 3)
    return HertzContact(a, 3 * F / (2 * math.pi * a ** 2), a ** 2 / R, E_star)
