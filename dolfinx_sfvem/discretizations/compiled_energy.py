"""Compiled pointwise kernels of an energy: Psi, P, T, D, A, B at one point (paper Eqs. 30, 32).

``P = dPsi/dF``, ``T = dPsi/dG``, ``D = dP/dF``, ``A = dT/dF``, ``B = dT/dG`` are taken
by ``ufl.diff`` on ``ufl.variable`` s F and G and compiled by FFCx into two C
functions of the ufcx signature ``f(out, w, c, x, entity_local_index, perm[, custom_data])``
(called from Python and numba through :func:`dolfinx_sfvem._compat.call_kernel`):

========  ==========================  ==============================  ======  =====================
function  ``uses_gradient``           output layout (row-major)       size    size in 3D
========  ==========================  ==============================  ======  =====================
residual  True                        ``[Psi, P(d²), T(d³)]``         13      37
tangent   True                        ``[D(d⁴), A(d⁵), B(d⁶)]``       112     81 + 243 + 729
residual  False                       ``[Psi, P(d²)]``                5       10
tangent   False                       ``[D(d⁴)]``                     16      81
========  ==========================  ==============================  ======  =====================

(The tangent function leaves P and T out: they would cost about 20 % more per call.)

with ``P_ij``, ``T_ijk``, ``D_ijmn = dP_ij/dF_mn``, ``A_ijkmn = dT_ijk/dF_mn``,
``B_ijkmnp = dT_ijk/dG_mnp``. The functions *add* into ``out``.

The spatial dimension d (2: plane strain, the default; 3) sets the shapes: F (d, d),
G (d, d, d) and so on (:func:`shapes`); the energies of :mod:`dolfinx_sfvem.physics.energy` take their
dimension from F. Constants ``c`` (one array serves both functions): ``[F(d²), G(d³), parameters]``,
``F`` at ``F_offset = 0`` and ``G`` at ``G_offset = d²`` (row-major; G is ignored
when ``uses_gradient`` is False), parameter ``name`` at ``param_offsets[name]``
(d² + d³, ... in :attr:`Energy.param_names` order: 12, 13, ... in 2D, 36, 37, ... in 3D).

Everything is one vector ``ufl.Constant``: FFCx packs only the constants that survive
derivative expansion, so separate constants could give the residual and the tangent
different packings (e.g. a parameter that only scales an F-independent term of Psi).
"""
from __future__ import annotations

import math
from collections.abc import Callable, Hashable, Mapping

import numpy as np
import numpy.typing as npt
import ufl
from mpi4py import MPI
from ufl.algorithms.apply_algebra_lowering import apply_algebra_lowering
from ufl.algorithms.apply_derivatives import apply_derivatives
from ufl.core.expr import Expr

from dolfinx_sfvem._compat import call_kernel, compile_pointwise_expression, coordinate_domain, kernel_scratch
from dolfinx_sfvem.physics.energy import Energy

#: Rank of each pointwise quantity (Eqs. 30, 32): its shape is (d,) * rank.
RANKS: dict[str, int] = {"psi": 0, "P": 2, "T": 3, "D": 4, "A": 5, "B": 6}

F_OFFSET = 0

_SCRATCH = kernel_scratch()


def shapes(dim: int = 2) -> dict[str, tuple[int, ...]]:
    """Shape of each pointwise quantity in ``dim`` dimensions; kernels return them flattened row-major."""
    return {name: (dim,) * rank for name, rank in RANKS.items()}


def _size(name: str, dim: int) -> int:
    return dim ** RANKS[name]


def layouts(uses_gradient: bool) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """Quantities stacked in the residual and in the tangent output, in order."""
    if uses_gradient:
        return ("psi", "P", "T"), ("D", "A", "B")
    return ("psi", "P"), ("D",)


def _offsets(layout: tuple[str, ...], dim: int) -> dict[str, int]:
    """Start of each quantity in an output array that stacks ``layout``."""
    starts = np.cumsum([0] + [_size(name, dim) for name in layout])
    return {name: int(start) for name, start in zip(layout, starts)}


class EnergyKernels:
    """The two compiled pointwise functions of one energy structure (one :attr:`Energy.key`) in one
    dimension.

    Attributes
    ----------
    dim : int
        Spatial dimension d (2 or 3).
    residual, tangent : ctypes function
        ufcx tabulate functions (they add into ``out``); layouts in the module docstring.
    uses_gradient : bool
        Whether T, A, B are part of the layouts.
    residual_layout, tangent_layout : tuple[str, ...]
        Quantities stacked in each output, e.g. ``("psi", "P", "T")``.
    residual_offsets, tangent_offsets : dict[str, int]
        Start of each quantity in the output arrays.
    n_residual, n_tangent : int
        Output sizes (13 and 112, or 5 and 16 without gradient, in 2D).
    n_constants, F_offset, G_offset : int
        Size of ``c`` and where F (d²) and G (d³) go.
    param_offsets : dict[str, int]
        Where each parameter goes in ``c``.
    """

    def __init__(self, energy: Energy, residual: Callable, tangent: Callable, modules: tuple, dim: int = 2):
        self.dim = dim
        self.residual = residual
        self.tangent = tangent
        self.uses_gradient = energy.uses_gradient
        self.residual_layout, self.tangent_layout = layouts(self.uses_gradient)
        self.residual_offsets = _offsets(self.residual_layout, dim)
        self.tangent_offsets = _offsets(self.tangent_layout, dim)
        self.n_residual = sum(_size(name, dim) for name in self.residual_layout)
        self.n_tangent = sum(_size(name, dim) for name in self.tangent_layout)
        self.F_offset = F_OFFSET
        self.G_offset = _param_offset(dim) - dim ** 3
        self.param_offsets = {name: _param_offset(dim) + n for n, name in enumerate(energy.param_names)}
        self.n_constants = _param_offset(dim) + len(self.param_offsets)
        self._validate = energy.validate
        self._modules = modules

    def pack_constants(self, params: Mapping[str, float] | None = None) -> npt.NDArray[np.float64]:
        """The constants array ``c``, shape (n_constants,).

        Parameters
        ----------
        params
            Value of every parameter (validated as by the energy's constructor);
            None only for an energy without parameters.

        Returns
        -------
        c : (n_constants,) float64
            Parameters at :attr:`param_offsets`; F = I and G = 0 (the reference state)
            until the caller writes F at :attr:`F_offset` and G at :attr:`G_offset`.
        """
        values = self._validate({} if params is None else params)
        c = np.zeros(self.n_constants)
        c[self.F_offset:self.F_offset + self.dim ** 2] = np.eye(self.dim).ravel()
        for name, value in values.items():
            c[self.param_offsets[name]] = value
        return c


def _param_offset(dim: int) -> int:
    """Where the parameters start in ``c``: after F (d²) and G (d³)."""
    return dim ** 2 + dim ** 3


def _block(c: ufl.Constant, offset: int, shape: tuple[int, ...]) -> Expr:
    """Components ``c[offset:offset + prod(shape)]`` as a UFL tensor of ``shape`` (row-major)."""
    components = np.array([c[offset + n] for n in range(math.prod(shape))], dtype=object)
    return ufl.as_tensor(components.reshape(shape).tolist())


def _stack(quantities: Mapping[str, Expr], layout: tuple[str, ...]) -> Expr:
    """The quantities of ``layout`` flattened row-major into one UFL vector."""
    components = []
    for name in layout:
        q = quantities[name]
        components += [q[index] for index in np.ndindex(q.ufl_shape)] if q.ufl_shape else [q]
    return ufl.as_vector(components)


def _is_zero(expression: Expr) -> bool:
    return isinstance(apply_derivatives(apply_algebra_lowering(expression)), ufl.classes.Zero)


def _compile(energy: Energy, comm: MPI.Comm, dim: int) -> EnergyKernels:
    domain = coordinate_domain("triangle")     # any domain: the expression holds only the constant c
    start = _param_offset(dim)
    c = ufl.Constant(domain, shape=(start + len(energy.param_names),))
    shape = shapes(dim)
    F = ufl.variable(_block(c, F_OFFSET, shape["P"]))
    G = ufl.variable(_block(c, start - dim ** 3, shape["T"]))
    p = {name: c[start + n] for n, name in enumerate(energy.param_names)}

    psi = energy.psi(F, G, p)
    P = ufl.diff(psi, F)  # Eq. 30
    T = ufl.diff(psi, G)  # Eq. 30
    if not energy.uses_gradient and not _is_zero(T):
        raise ValueError(f"{energy.name}: declared uses_gradient=False, but psi depends on G")
    quantities = {"psi": psi, "P": P, "T": T, "D": ufl.diff(P, F), "A": ufl.diff(T, F), "B": ufl.diff(T, G)}

    residual_layout, tangent_layout = layouts(energy.uses_gradient)
    residual, residual_module = compile_pointwise_expression(comm, _stack(quantities, residual_layout))
    tangent, tangent_module = compile_pointwise_expression(comm, _stack(quantities, tangent_layout))
    return EnergyKernels(energy, residual, tangent, (residual_module, tangent_module), dim)


_CACHE: dict[Hashable, EnergyKernels] = {}


def compile_kernels(energy: Energy, comm: MPI.Comm = MPI.COMM_WORLD, dim: int = 2) -> EnergyKernels:
    """Compile (or fetch from the in-process cache) the kernels of ``energy``'s structure in ``dim``
    (2: plane strain, or 3) dimensions.

    One :class:`EnergyKernels` serves every parameter value of the same
    :attr:`Energy.key` and dimension. Collective over ``comm`` on the first call for a key
    (FFCx compiles on rank 0 and caches on disk).

    Raises
    ------
    ValueError
        If ``energy.uses_gradient`` is False but Psi depends on G.
    """
    if dim not in (2, 3):
        raise ValueError(f"compile_kernels: dim={dim!r}, must be 2 or 3")
    key = energy.key if dim == 2 else (energy.key, dim)
    kernels = _CACHE.get(key)
    if kernels is None:
        kernels = _CACHE[key] = _compile(energy, comm, dim)
    return kernels


def tabulate(function: Callable, size: int, c: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Call a compiled kernel function once from Python (ctypes).

    Parameters
    ----------
    function
        :attr:`EnergyKernels.residual` or :attr:`EnergyKernels.tangent`.
    size
        Its output size (:attr:`EnergyKernels.n_residual` / ``n_tangent``).
    c : (n_constants,) float64
        Constants with F, G and parameters filled in.
    """
    out = np.zeros(size)
    c = np.ascontiguousarray(c, dtype=np.float64)
    call_kernel(function, out, c, _SCRATCH)
    return out


def evaluate(kernels: EnergyKernels, F: npt.ArrayLike, G: npt.ArrayLike | None = None,
             params: Mapping[str, float] | None = None) -> dict[str, npt.NDArray[np.float64] | float]:
    """Psi, P, T, D, A, B at one point, through the compiled functions.

    Parameters
    ----------
    kernels
        From :func:`compile_kernels`.
    F : (d, d)
        Deformation gradient, d = ``kernels.dim``.
    G : (d, d, d) or None
        ``G_ijk = dF_ij/dX_k``; None means 0 (ignored when the energy does not use G).
    params
        Parameter values (see :meth:`EnergyKernels.pack_constants`).

    Returns
    -------
    dict
        ``"psi"`` float; ``"P"`` (d, d), ``"T"`` (d, d, d), ``"D"`` (d,)*4, ``"A"`` (d,)*5,
        ``"B"`` (d,)*6, indexed as in the module docstring; T, A, B are zero when the
        energy does not use G.
    """
    d = kernels.dim
    shape = shapes(d)
    c = kernels.pack_constants(params)
    c[kernels.F_offset:kernels.F_offset + d ** 2] = np.asarray(F, dtype=np.float64).reshape(shape["P"]).ravel()
    if G is not None:
        c[kernels.G_offset:kernels.G_offset + d ** 3] = np.asarray(G, dtype=np.float64).reshape(shape["T"]).ravel()
    result = {name: np.zeros(s) for name, s in shape.items()}
    for function, size, offsets in ((kernels.tangent, kernels.n_tangent, kernels.tangent_offsets),
                                    (kernels.residual, kernels.n_residual, kernels.residual_offsets)):
        out = tabulate(function, size, c)
        for name, start in offsets.items():
            result[name] = out[start:start + _size(name, d)].reshape(shape[name])
    result["psi"] = float(result["psi"])
    return result
