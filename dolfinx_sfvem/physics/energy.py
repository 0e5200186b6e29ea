"""Strain-energy densities Psi(F, G) of the paper's §2, written once in UFL.

Every energy is a function of the deformation gradient ``F`` (d, d) and of its
material gradient ``G`` (d, d, d), ``G_ijk = dF_ij/dX_k = d^2 u_i / dX_j dX_k``
(not symmetrised in j, k), and of named scalar parameters; d = 2 (plane strain) or 3,
read from ``F.ufl_shape``. The same :meth:`Energy.psi` serves

- the pointwise kernels of the SFVEM (:mod:`dolfinx_sfvem.discretizations.compiled_energy`), where ``F``
  and ``G`` are ``ufl.variable`` s of constants, and
- the P2/Q2 FEM reference, where ``F = ufl.variable(I + grad(u))`` and
  ``G = grad(grad(u))``.

In 2D the energies are those of plane strain: the 3D deformation gradient is
``[[F, 0], [0, 1]]`` and ``grad F`` has no out-of-plane parts, so ``tr C = tr(F^T F) + 1``,
``J = det F``, and every formula below is the 3D one evaluated on that embedding (a one-layer
slab with ``u_z = 0`` reproduces the 2D energies exactly; tests/test_energy.py). Parameters
and energies are in consistent (unit-free) stress units.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Hashable, Mapping

import ufl
from ufl.core.expr import Expr

from dolfinx_sfvem import _compat

#: A parameter's admissible range: ``(bound, strict)`` means value > bound (strict)
#: or value >= bound; ``None`` admits every finite real number.
Bound = tuple[float, bool] | None
POSITIVE: Bound = (0.0, True)
NON_NEGATIVE: Bound = (0.0, False)

#: The quadrature rules an energy may ask of a discretization (:attr:`Energy.quadrature`):
#: "gauss", the discretization's own rule; "lobatto", Gauss-Lobatto points at the element's
#: nodes (the FEM's Q2 quadrilaterals and hexahedra only); "reduced", the lowest Gauss rule exact
#: for the linear-elastic stiffness (the FEM's P2 triangles and tetrahedra only).
QUADRATURES = ("gauss", "lobatto", "reduced")


# --------------------------------------------------------------------------- kinematics
def dim(F: Expr) -> int:
    """Spatial dimension d of ``F`` (d, d): 2 (plane strain) or 3."""
    return F.ufl_shape[0]


def J(F: Expr) -> Expr:
    """Volume ratio ``J = det F`` (in plane strain ``F_33 = 1``)."""
    return ufl.det(F)


def tr_C(F: Expr) -> Expr:
    """``tr C`` of the 3D right Cauchy-Green tensor ``C = F^T F``; in plane strain ``C_33 = 1`` is added."""
    return ufl.tr(F.T * F) + (3 - dim(F))


def material_gradient(f: Callable[[Expr], Expr], F: Expr, G: Expr) -> Expr:
    """Material gradient of a function of F by the chain rule: shape (d,) for a scalar f,
    (m, d) for a vector f of length m.

    ``(grad f)_k = df/dF_ij G_ijk`` (paper Eq. 17 for ``f = det``); ``df/dF`` is
    taken by ``ufl.diff`` on a fresh ``ufl.variable`` of F, so F may be any
    expression, and outer derivatives (``ufl.diff`` / ``ufl.derivative``) pass through.
    """
    Fv = ufl.variable(F)
    value = f(Fv)
    dfdF = ufl.diff(value, Fv)
    i, j, k = ufl.indices(3)
    if value.ufl_shape == ():
        return ufl.as_vector(dfdF[i, j] * G[i, j, k], k)
    m = ufl.Index()
    return ufl.as_tensor(dfdF[m, i, j] * G[i, j, k], (m, k))


# --------------------------------------------------------------------------- bulk energy
def neo_hookean(F: Expr, K: Expr, mu: Expr) -> Expr:
    """Paper Eq. 2 (and Eq. 4): ``K/2 (ln J)^2 + mu/2 (J^(-2/3) tr C - 3)``."""
    return K / 2 * ufl.ln(J(F)) ** 2 + mu / 2 * (J(F) ** (-2 / 3) * tr_C(F) - 3)


# --------------------------------------------------------------------------- regularizations (Table 1)
def skew_axial(F: Expr) -> Expr:
    """``w = axial(F - F^T)`` with the sign of Eq. 12: in 3D ``(F23 - F32, F31 - F13, F12 - F21)``
    (1-based), in 2D its only plane-strain component ``(F12 - F21,)``. For a rotation by an
    angle phi about a unit axis a, ``w = 2 sin(phi) a`` up to the sign convention of Eq. 12."""
    if dim(F) == 2:
        return ufl.as_vector([F[0, 1] - F[1, 0]])
    return ufl.as_vector([F[1, 2] - F[2, 1], F[2, 0] - F[0, 2], F[0, 1] - F[1, 0]])


def rotation_cosine(F: Expr) -> Expr:
    """``tr F - 1`` of the 3D deformation gradient (``2 cos(phi)`` for a rotation by phi); in plane
    strain ``F11 + F22`` (Eq. 12's denominator)."""
    return ufl.tr(F) + (2 - dim(F))


def rotation_angle(F: Expr) -> Expr:
    """Rotation angles of Eq. 12, one per axis: ``phi_i = atan2(w_i, tr F - 1)`` with ``w``
    from :func:`skew_axial`; shape (1,) in 2D, where it is ``atan((F12 - F21) / (F11 + F22))``,
    and (3,) in 3D, where ``phi_i`` is the rotation about axis i for a rotation about that axis.

    Written with ``atan2``: it has the same derivative wherever the quotient is
    defined and stays finite when ``F11 + F22 = 0``. (Eq. 12 as printed gives minus
    the polar rotation angle of ``F``; only ``grad phi : grad phi`` enters Psi_r.) In plane
    strain the out-of-plane angles are ``atan2(0, F11 + F22)``, constant: Eq. 15 is the 2D one.
    """
    w = skew_axial(F)
    c = rotation_cosine(F)
    return ufl.as_vector([_compat.atan2(w[i], c) for i in range(w.ufl_shape[0])])


def tan_rotation_angle(F: Expr) -> Expr:
    """``t = w / (tr F - 1)`` of Eq. 16, shape (1,) in 2D (``(F12 - F21) / (F11 + F22) = tan(phi)``),
    (3,) in 3D (``tan(phi) a`` for a rotation by phi about the unit axis a: the skew part of F
    over its trace, as in Wriggers et al. 2025); singular at ``tr F = 1``."""
    return skew_axial(F) / rotation_cosine(F)


def huhu(F: Expr, G: Expr) -> Expr:
    """Eq. 6: ``Psi_r = 1/2 G:G``."""
    return ufl.inner(G, G) / 2


def huhu_lulu(F: Expr, G: Expr, n_dim: int | None = None) -> Expr:
    """Eq. 9: ``Psi_r = 1/2 (G:G - L.L / n_dim)`` with ``L_i = G_ijj``; ``n_dim`` defaults to the
    dimension of F (with n_dim = 2 the 3D form reduces to the 2D one in plane strain)."""
    i, j = ufl.indices(2)
    L = ufl.as_vector(G[i, j, j], i)
    n_dim = dim(F) if n_dim is None else n_dim
    return (ufl.inner(G, G) - ufl.dot(L, L) / n_dim) / 2


def rotation(F: Expr, G: Expr) -> Expr:
    """Eq. 15: ``Psi_r = 1/2 (grad phi : grad phi + grad J . grad J)``, phi from Eq. 12
    (:func:`rotation_angle`, one angle per axis in 3D), grad J from Eq. 17."""
    grad_phi = material_gradient(rotation_angle, F, G)
    grad_J = material_gradient(J, F, G)
    return (ufl.inner(grad_phi, grad_phi) + ufl.dot(grad_J, grad_J)) / 2


def tan_rotation(F: Expr, G: Expr) -> Expr:
    """Eq. 16: as Eq. 15 with ``t = tan(phi)`` in place of phi (:func:`tan_rotation_angle`; not
    objective: ``grad t = (1 + t^2) grad phi`` in 2D)."""
    grad_t = material_gradient(tan_rotation_angle, F, G)
    grad_J = material_gradient(J, F, G)
    return (ufl.inner(grad_t, grad_t) + ufl.dot(grad_J, grad_J)) / 2


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
        (:mod:`~dolfinx_sfvem.physics.contact`, :mod:`~dolfinx_sfvem.discretizations.injectivity`).
    quadrature : str
        A key of :data:`QUADRATURES`: where Psi is integrated. "gauss" (the default): the
        discretization's own rule; "lobatto": the Gauss-Lobatto rule whose points are the nodes of
        the FEM's Q2 cells, so that Psi (and ln J) is evaluated where the element can turn over
        first (its corners); "reduced": the lowest Gauss rule that integrates the linear-elastic
        stiffness exactly (degree 2 on the FEM's P2 triangles and tetrahedra: 3 and 4 points), so
        that a squeezed P2 cell is judged and priced where its strain is, not near its curved
        edges; the discretizations that have no such rule refuse it.
    """

    uses_gradient: bool = True
    is_medium: bool = False
    quadrature: str = "gauss"

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
    n_dim : int or None
        ``n_dim`` of Eq. 9 (``"huhu_lulu"`` only); None (default): the dimension of the mesh.
        2 on a 3D mesh gives the 3D energy that equals the 2D one in plane strain.
    quadrature : str
        ``"gauss"`` (default), ``"lobatto"`` or ``"reduced"``: see :attr:`Energy.quadrature`. The
        energy is the same; only where the FEM integrates it changes (the Q2 nodes, or the degree-2
        Gauss points of P2 simplices, instead of the default Gauss points).
    beta1 : float >= 0 or None
        Weight of a skew penalty ``beta1/2 |w(F)|^2`` (w from :func:`skew_axial`), added outside
        the factor gamma: the local part of the rotation regularization of Wriggers et al. 2025
        (their ``Pi_R = beta1/2 |w - p/d|^2 + beta2/2 |grad p|^2`` with the auxiliary field p = 0).
        None (default): no such term.
    """

    is_medium = True

    def __init__(self, mu: float, gamma: float, alpha_r: float, regularization: str = "rotation",
                 beta: float | None = None, K: float = 0.0, n_dim: int | None = None, quadrature: str = "gauss",
                 beta1: float | None = None):
        if regularization not in REGULARIZATIONS:
            raise ValueError(f"ThirdMedium: unknown regularization {regularization!r}; "
                             f"valid: {sorted(REGULARIZATIONS)}")
        if quadrature not in QUADRATURES:
            raise ValueError(f"ThirdMedium: unknown quadrature {quadrature!r}; valid: {list(QUADRATURES)}")
        self.quadrature = quadrature
        if n_dim is not None and (regularization != "huhu_lulu" or n_dim not in (2, 3)):
            raise ValueError(f"ThirdMedium: n_dim={n_dim!r} is a parameter of the 'huhu_lulu' "
                             "regularization (Eq. 9) and must be 2 or 3")
        self.regularization = regularization
        self.n_dim = n_dim
        self.scaled = beta is not None
        params = {"mu": mu, "gamma": gamma, "alpha_r": alpha_r, "K": K}
        bounds = {"mu": POSITIVE, "gamma": POSITIVE, "alpha_r": NON_NEGATIVE, "K": NON_NEGATIVE}
        if self.scaled:
            params["beta"] = beta
            bounds["beta"] = NON_NEGATIVE
        self.skew_penalty = beta1 is not None
        if self.skew_penalty:
            params["beta1"] = beta1
            bounds["beta1"] = NON_NEGATIVE
        super().__init__(params, bounds)

    @property
    def key(self) -> Hashable:
        return (ThirdMedium, REGULARIZATIONS[self.regularization], self.scaled, self.n_dim, self.skew_penalty)

    def psi(self, F: Expr, G: Expr, p: Mapping[str, Expr]) -> Expr:
        s = ufl.exp(-p["beta"] * J(F)) if self.scaled else 1
        options = {} if self.n_dim is None else {"n_dim": self.n_dim}
        psi_r = REGULARIZATIONS[self.regularization](F, G, **options)
        psi = p["gamma"] * (neo_hookean(F, p["K"], p["mu"]) + p["alpha_r"] * s * psi_r)
        if self.skew_penalty:
            w = skew_axial(F)
            psi = psi + p["beta1"] / 2 * ufl.dot(w, w)
        return psi

    def unregularized_params(self) -> dict[str, float]:
        """Its values with alpha_r = 0 (and beta1 = 0): Psi = gamma [K/2 (ln J)^2 + mu/2 (J^(-2/3) tr C - 3)],
        the neo-Hookean part of Eq. 3."""
        return {**self.params, "alpha_r": 0.0, **({"beta1": 0.0} if self.skew_penalty else {})}

    @property
    def name(self) -> str:
        n_dim = "" if self.n_dim is None else f", n_dim={self.n_dim}"
        quadrature = "" if self.quadrature == "gauss" else f", {self.quadrature}"
        skew = ", skew penalty" if self.skew_penalty else ""
        return f"ThirdMedium[{self.regularization}{n_dim}{quadrature}{skew}]"


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
    :class:`~dolfinx_sfvem.physics.loads.CavityPressure` with p set to λ p_0 at every load factor λ.

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
