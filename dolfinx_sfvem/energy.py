"""Strain-energy densities Psi(F, G) of the paper's §2, written once in UFL.

Every energy is a function of the deformation gradient ``F`` (2, 2) and of its
material gradient ``G`` (2, 2, 2), ``G_ijk = dF_ij/dX_k = d^2 u_i / dX_j dX_k``
(not symmetrised in j, k), and of named scalar parameters. The same
:meth:`Energy.psi` serves

- the pointwise kernels of the SFVEM (:mod:`dolfinx_sfvem.compiled_energy`), where ``F``
  and ``G`` are ``ufl.variable`` s of constants, and
- the P2 FEM reference, where ``F = ufl.variable(I + grad(u))`` and
  ``G = grad(grad(u))``.

Plane strain throughout: ``C = F^T F`` with ``C_33 = 1``, so ``tr C = tr(C_2x2) + 1``
and ``J = det F``. Parameters and energies are in consistent (unit-free) stress units.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Hashable, Mapping

import ufl
from ufl.core.expr import Expr

from . import _compat

#: A parameter's admissible range: ``(bound, strict)`` means value > bound (strict)
#: or value >= bound; ``None`` admits every finite real number.
Bound = tuple[float, bool] | None
POSITIVE: Bound = (0.0, True)
NON_NEGATIVE: Bound = (0.0, False)


# --------------------------------------------------------------------------- kinematics
def J(F: Expr) -> Expr:
    """Volume ratio ``J = det F`` (plane strain, ``F_33 = 1``)."""
    return ufl.det(F)


def tr_C(F: Expr) -> Expr:
    """``tr C`` of the 3D right Cauchy-Green tensor in plane strain: ``tr(F^T F) + C_33``, ``C_33 = 1``."""
    return ufl.tr(F.T * F) + 1


def material_gradient(f: Callable[[Expr], Expr], F: Expr, G: Expr) -> Expr:
    """Material gradient of a scalar function of F by the chain rule, shape (2,).

    ``(grad f)_k = df/dF_ij G_ijk`` (paper Eq. 17 for ``f = det``); ``df/dF`` is
    taken by ``ufl.diff`` on a fresh ``ufl.variable`` of F, so F may be any
    expression, and outer derivatives (``ufl.diff`` / ``ufl.derivative``) pass through.
    """
    Fv = ufl.variable(F)
    dfdF = ufl.diff(f(Fv), Fv)
    i, j, k = ufl.indices(3)
    return ufl.as_vector(dfdF[i, j] * G[i, j, k], k)


# --------------------------------------------------------------------------- bulk energy
def neo_hookean(F: Expr, K: Expr, mu: Expr) -> Expr:
    """Paper Eq. 2 (and Eq. 4): ``K/2 (ln J)^2 + mu/2 (J^(-2/3) tr C - 3)``."""
    return K / 2 * ufl.ln(J(F)) ** 2 + mu / 2 * (J(F) ** (-2 / 3) * tr_C(F) - 3)


# --------------------------------------------------------------------------- regularizations (Table 1)
def rotation_angle(F: Expr) -> Expr:
    """Rotation angle of Eq. 12, ``phi = atan((F12 - F21) / (F11 + F22))``.

    Written with ``atan2``: it has the same derivative wherever the quotient is
    defined and stays finite when ``F11 + F22 = 0``. (Eq. 12 as printed gives minus
    the polar rotation angle of ``F``; only ``grad phi . grad phi`` enters Psi_r.)
    """
    return _compat.atan2(F[0, 1] - F[1, 0], F[0, 0] + F[1, 1])


def tan_rotation_angle(F: Expr) -> Expr:
    """``t = (F12 - F21) / (F11 + F22) = tan(phi)`` of Eq. 16 (singular at ``F11 + F22 = 0``)."""
    return (F[0, 1] - F[1, 0]) / (F[0, 0] + F[1, 1])


def huhu(F: Expr, G: Expr) -> Expr:
    """Eq. 6: ``Psi_r = 1/2 G:G``."""
    return ufl.inner(G, G) / 2


def huhu_lulu(F: Expr, G: Expr) -> Expr:
    """Eq. 9: ``Psi_r = 1/2 (G:G - L.L / n_dim)`` with ``L_i = G_ijj``."""
    i, j = ufl.indices(2)
    L = ufl.as_vector(G[i, j, j], i)
    n_dim = F.ufl_shape[0]
    return (ufl.inner(G, G) - ufl.dot(L, L) / n_dim) / 2


def rotation(F: Expr, G: Expr) -> Expr:
    """Eq. 15: ``Psi_r = 1/2 (grad phi . grad phi + grad J . grad J)``, phi from Eq. 12, grad J from Eq. 17."""
    grad_phi = material_gradient(rotation_angle, F, G)
    grad_J = material_gradient(J, F, G)
    return (ufl.dot(grad_phi, grad_phi) + ufl.dot(grad_J, grad_J)) / 2


def tan_rotation(F: Expr, G: Expr) -> Expr:
    """Eq. 16: as Eq. 15 with ``t = tan(phi)`` in place of phi (not objective: ``grad t = (1 + t^2) grad phi``)."""
    grad_t = material_gradient(tan_rotation_angle, F, G)
    grad_J = material_gradient(J, F, G)
    return (ufl.dot(grad_t, grad_t) + ufl.dot(grad_J, grad_J)) / 2


#: The regularizations of Table 1, by name: ``Psi_r(F, G)``.
REGULARIZATIONS: dict[str, Callable[[Expr, Expr], Expr]] = {
    "huhu": huhu,
    "huhu_lulu": huhu_lulu,
    "rotation": rotation,
    "tan_rotation": tan_rotation,
}


# --------------------------------------------------------------------------- energies
class Energy:
    """A strain-energy density ``Psi(F, G; p)`` with named scalar parameters.

    Attributes
    ----------
    params : dict[str, float]
        Current parameter values, in the order of :attr:`param_names`.
    uses_gradient : bool
        False when Psi does not depend on G; then T, A and B vanish and callers skip them.
    is_medium : bool
        True for a third medium: its elements may be squeezed flat between solids in
        contact, and it is not a body whose overlap with others is measured
        (:mod:`~dolfinx_sfvem.contact`, :mod:`~dolfinx_sfvem.injectivity`).
    """

    uses_gradient: bool = True
    is_medium: bool = False

    def __init__(self, params: Mapping[str, float], bounds: Mapping[str, Bound]):
        self._bounds = dict(bounds)
        self.params = self.validate(params)

    @property
    def name(self) -> str:
        """Name used in messages."""
        return type(self).__name__

    @property
    def param_names(self) -> tuple[str, ...]:
        """Parameter names, in the order they are packed into a kernel's constants."""
        return tuple(self._bounds)

    @property
    def key(self) -> Hashable:
        """Identifies the structure of Psi (not the parameter values): one compiled kernel per key."""
        raise NotImplementedError

    def psi(self, F: Expr, G: Expr, p: Mapping[str, Expr]) -> Expr:
        """Strain-energy density.

        Parameters
        ----------
        F : UFL expression, shape (2, 2)
            Deformation gradient.
        G : UFL expression, shape (2, 2, 2)
            Its material gradient, ``G_ijk = dF_ij/dX_k``.
        p
            Parameter name -> scalar UFL expression (a constant).
        """
        raise NotImplementedError

    def unregularized_params(self) -> dict[str, float]:
        """Parameter values that leave the energy's numerical regularization out: Ψ is then the
        material's own response, whose forces on the solids are the contact pressure
        (docs/contact.md, "Pressure recovery"). An energy without a regularization it can name
        (a solid, a :class:`UserEnergy`) is all material response: its own values."""
        return dict(self.params)

    def validate(self, values: Mapping[str, float]) -> dict[str, float]:
        """Check a full set of parameter values; return them as floats in :attr:`param_names` order.

        Raises
        ------
        ValueError
            On missing or unknown names, non-finite values or values out of range;
            the message names the parameter.
        """
        missing = [n for n in self._bounds if n not in values]
        unknown = [n for n in values if n not in self._bounds]
        if missing or unknown:
            raise ValueError(f"{self.name}: missing parameter(s) {missing}, unknown parameter(s) {unknown}; "
                             f"expected {list(self._bounds)}")
        checked = {}
        for name, bound in self._bounds.items():
            value = values[name]
            try:
                value = float(value)
            except (TypeError, ValueError):
                raise ValueError(f"{self.name}: parameter '{name}' must be a real number, got {value!r}") from None
            if not math.isfinite(value):
                raise ValueError(f"{self.name}: parameter '{name}' must be finite, got {value}")
            if bound is not None:
                lower, strict = bound
                if value < lower or (strict and value == lower):
                    raise ValueError(f"{self.name}: parameter '{name}' must be {'>' if strict else '>='} {lower}, "
                                     f"got {value}")
            checked[name] = value
        return checked

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.params.items())
        return f"{self.name}({args})"


class Hyperelastic(Energy):
    """Solid, paper Eq. 2: ``Psi = K/2 (ln J)^2 + mu/2 (J^(-2/3) tr C - 3)``.

    Parameters
    ----------
    K, mu
        Bulk and shear modulus, both > 0.
    """

    uses_gradient = False

    def __init__(self, K: float, mu: float):
        super().__init__({"K": K, "mu": mu}, {"K": POSITIVE, "mu": POSITIVE})

    @property
    def key(self) -> Hashable:
        return (Hyperelastic,)

    def psi(self, F: Expr, G: Expr, p: Mapping[str, Expr]) -> Expr:
        return neo_hookean(F, p["K"], p["mu"])


class ThirdMedium(Energy):
    """Third medium, paper Eqs. 3-5 and 8:
    ``Psi = gamma [K/2 (ln J)^2 + mu/2 (J^(-2/3) tr C - 3) + alpha_r s(J) Psi_r(F, G)]``.

    Parameters
    ----------
    mu : float > 0
        Shear modulus of the medium.
    gamma : float > 0
        Overall scaling of the medium (Eq. 3).
    alpha_r : float >= 0
        Weight of the regularization (Eq. 3).
    regularization : str
        A key of :data:`REGULARIZATIONS` (Table 1).
    beta : float >= 0 or None
        Scaling ``s(J) = exp(-beta J)`` (Eq. 8 with ``|F| = det F`` as in Appendix B);
        None switches the scaling off (``s = 1``).
    K : float >= 0
        Bulk modulus; 0 (default) gives Eq. 5.
    """

    is_medium = True

    def __init__(self, mu: float, gamma: float, alpha_r: float, regularization: str = "rotation",
                 beta: float | None = None, K: float = 0.0):
        if regularization not in REGULARIZATIONS:
            raise ValueError(f"ThirdMedium: unknown regularization {regularization!r}; "
                             f"valid: {sorted(REGULARIZATIONS)}")
        self.regularization = regularization
        self.scaled = beta is not None
        params = {"mu": mu, "gamma": gamma, "alpha_r": alpha_r, "K": K}
        bounds = {"mu": POSITIVE, "gamma": POSITIVE, "alpha_r": NON_NEGATIVE, "K": NON_NEGATIVE}
        if self.scaled:
            params["beta"] = beta
            bounds["beta"] = NON_NEGATIVE
        super().__init__(params, bounds)

    @property
    def key(self) -> Hashable:
        return (ThirdMedium, REGULARIZATIONS[self.regularization], self.scaled)

    def psi(self, F: Expr, G: Expr, p: Mapping[str, Expr]) -> Expr:
        s = ufl.exp(-p["beta"] * J(F)) if self.scaled else 1
        psi_r = REGULARIZATIONS[self.regularization](F, G)
        return p["gamma"] * (neo_hookean(F, p["K"], p["mu"]) + p["alpha_r"] * s * psi_r)

    def unregularized_params(self) -> dict[str, float]:
        """Its values with alpha_r = 0: Psi = gamma [K/2 (ln J)^2 + mu/2 (J^(-2/3) tr C - 3)], the
        neo-Hookean part of Eq. 3."""
        return {**self.params, "alpha_r": 0.0}

    @property
    def name(self) -> str:
        return f"ThirdMedium[{self.regularization}]"


class UserEnergy(Energy):
    """Any user-written UFL energy ``psi_fn(F, G, **p)``.

    Parameters
    ----------
    psi_fn
        ``psi_fn(F, G, **p) -> scalar UFL expression``; ``p`` holds one scalar
        UFL expression per keyword of ``params``.
    uses_gradient
        Whether ``psi_fn`` depends on G (checked when the kernels are compiled).
    name
        Name used in messages (default: ``psi_fn.__name__``).
    medium
        True if this energy is a third medium (see :attr:`Energy.is_medium`); default False: a solid.
    **params
        Parameter values (finite floats); their names are the keywords of ``psi_fn``.
    """

    def __init__(self, psi_fn: Callable[..., Expr], uses_gradient: bool = True, name: str | None = None,
                 medium: bool = False, **params: float):
        self.psi_fn = psi_fn
        self.uses_gradient = uses_gradient
        self.is_medium = bool(medium)
        self._name = name or getattr(psi_fn, "__name__", "UserEnergy")
        super().__init__(params, dict.fromkeys(params))

    @property
    def name(self) -> str:
        return self._name

    @property
    def key(self) -> Hashable:
        return (UserEnergy, self.psi_fn, self.uses_gradient, self.param_names)

    def psi(self, F: Expr, G: Expr, p: Mapping[str, Expr]) -> Expr:
        return self.psi_fn(F, G, **p)


class VolumeWork(Energy):
    """``Psi = -p (J - 1)``: the work of a pressure p on the change of area (plane strain: of
    volume per unit thickness), integrated over a region filled with third medium it is the
    pneumatic load of a closed cavity (Faltus et al. 2024): the exact follower load of the
    enclosed area, with a symmetric tangent. Used by
    :class:`~dolfinx_sfvem.loads.CavityPressure` with p set to λ p_0 at every load factor λ.

    Parameters
    ----------
    p : float
        Pressure (stress units; p > 0 inflates).
    uses_gradient : bool
        Declared as the region's energy does (Psi never depends on G; the SFVEM assembles a term
        with the basis tables of its region, which hold the second derivatives when the
        region's energy uses them).
    """

    def __init__(self, p: float, uses_gradient: bool = False):
        self.uses_gradient = bool(uses_gradient)
        super().__init__({"p": p}, {"p": None})

    @property
    def key(self) -> Hashable:
        return (VolumeWork, self.uses_gradient)

    def psi(self, F: Expr, G: Expr, p: Mapping[str, Expr]) -> Expr:
        return -p["p"] * (J(F) - 1)
