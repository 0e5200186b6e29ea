"""Compiled pointwise kernels of an energy: Psi, P, T, D, A, B at one point (paper Eqs. 30, 32).

``P = dPsi/dF``, ``T = dPsi/dG``, ``D = dP/dF``, ``A = dT/dF``, ``B = dT/dG`` are taken
by ``ufl.diff`` on ``ufl.variable`` s F and G and compiled by FFCx into two C
functions of the ufcx signature ``f(out, w, c, x, entity_local_index, perm[, custom_data])``
(called from Python and numba through :func:`dolfinx_sfvem._compat.call_kernel`):

========  ==========================  ==============================  ======
function  ``uses_gradient``           output layout (row-major)       size
========  ==========================  ==============================  ======
residual  True                        ``[Psi, P(4), T(8)]``           13
tangent   True                        ``[D(16), A(32), B(64)]``       112
residual  False                       ``[Psi, P(4)]``                 5
tangent   False                       ``[D(16)]``                     16
========  ==========================  ==============================  ======

(The tangent function leaves P and T out: they would cost about 20 % more per call.)

with ``P_ij``, ``T_ijk``, ``D_ijmn = dP_ij/dF_mn``, ``A_ijkmn = dT_ijk/dF_mn``,
``B_ijkmnp = dT_ijk/dG_mnp``. The functions *add* into ``out``.

Constants ``c`` (one array serves both functions): ``[F(4), G(8), parameters]``,
``F`` at ``F_offset = 0`` and ``G`` at ``G_offset = 4`` (row-major; G is ignored
when ``uses_gradient`` is False), parameter ``name`` at ``param_offsets[name]``
(12, 13, ... in :attr:`Energy.param_names` order).

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
from dolfinx_sfvem.energy import Energy

#: Shape of each pointwise quantity (Eqs. 30, 32); kernels return them flattened row-major.
SHAPES: dict[str, tuple[int, ...]] = {"psi": (), "P": (2, 2), "T": (2, 2, 2), "D": (2,) * 4, "A": (2,) * 5,
                                      "B": (2,) * 6}

F_OFFSET = 0
G_OFFSET = 4
PARAM_OFFSET = 12

_SCRATCH = kernel_scratch()


def _size(name: str) -> int:
    return math.prod(SHAPES[name])


def layouts(uses_gradient: bool) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """Quantities stacked in the residual and in the tangent output, in order."""
    if uses_gradient:
        return ("psi", "P", "T"), ("D", "A", "B")
    return ("psi", "P"), ("D",)


def _offsets(layout: tuple[str, ...]) -> dict[str, int]:
    """Start of each quantity in an output array that stacks ``layout``."""
    starts = np.cumsum([0] + [_size(name) for name in layout])
    return {name: int(start) for name, start in zip(layout, starts)}


class EnergyKernels:
    """The two compiled pointwise functions of one energy structure (one :attr:`Energy.key`).

    Attributes
    ----------
    residual, tangent : ctypes function
        ufcx tabulate functions (they add into ``out``); layouts in the module docstring.
    uses_gradient : bool
        Whether T, A, B are part of the layouts.
    residual_layout, tangent_layout : tuple[str, ...]
        Quantities stacked in each output, e.g. ``("psi", "P", "T")``.
    residual_offsets, tangent_offsets : dict[str, int]
        Start of each quantity in the output arrays.
    n_residual, n_tangent : int
        Output sizes (13 and 112, or 5 and 16 without gradient).
    n_constants, F_offset, G_offset : int
        Size of ``c`` and where F (4) and G (8) go.
    param_offsets : dict[str, int]
        Where each parameter goes in ``c``.
    """

    def __init__(self, energy: Energy, residual: Callable, tangent: Callable, modules: tuple):
        self.residual = residual
        self.tangent = tangent
        self.uses_gradient = energy.uses_gradient
        self.residual_layout, self.tangent_layout = layouts(self.uses_gradient)
        self.residual_offsets = _offsets(self.residual_layout)
        self.tangent_offsets = _offsets(self.tangent_layout)
        self.n_residual = sum(_size(name) for name in self.residual_layout)
        self.n_tangent = sum(_size(name) for name in self.tangent_layout)
        self.F_offset = F_OFFSET
        self.G_offset = G_OFFSET
        self.param_offsets = {name: PARAM_OFFSET + n for n, name in enumerate(energy.param_names)}
        self.n_constants = PARAM_OFFSET + len(self.param_offsets)
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
        c[self.F_offset:self.F_offset + 4] = (1.0, 0.0, 0.0, 1.0)
        for name, value in values.items():
            c[self.param_offsets[name]] = value
        return c


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


def _compile(energy: Energy, comm: MPI.Comm) -> EnergyKernels:
    domain = coordinate_domain("triangle")
    c = ufl.Constant(domain, shape=(PARAM_OFFSET + len(energy.param_names),))
    F = ufl.variable(_block(c, F_OFFSET, SHAPES["P"]))
    G = ufl.variable(_block(c, G_OFFSET, SHAPES["T"]))
    p = {name: c[PARAM_OFFSET + n] for n, name in enumerate(energy.param_names)}

    psi = energy.psi(F, G, p)
    P = ufl.diff(psi, F)  # Eq. 30
    T = ufl.diff(psi, G)  # Eq. 30
    if not energy.uses_gradient and not _is_zero(T):
        raise ValueError(f"{energy.name}: declared uses_gradient=False, but psi depends on G")
    quantities = {"psi": psi, "P": P, "T": T, "D": ufl.diff(P, F), "A": ufl.diff(T, F), "B": ufl.diff(T, G)}

    residual_layout, tangent_layout = layouts(energy.uses_gradient)
    residual, residual_module = compile_pointwise_expression(comm, _stack(quantities, residual_layout))
    tangent, tangent_module = compile_pointwise_expression(comm, _stack(quantities, tangent_layout))
    return EnergyKernels(energy, residual, tangent, (residual_module, tangent_module))


_CACHE: dict[Hashable, EnergyKernels] = {}


def compile_kernels(energy: Energy, comm: MPI.Comm = MPI.COMM_WORLD) -> EnergyKernels:
    """Compile (or fetch from the in-process cache) the kernels of ``energy``'s structure.

    One :class:`EnergyKernels` serves every parameter value of the same
    :attr:`Energy.key`. Collective over ``comm`` on the first call for a key
    (FFCx compiles on rank 0 and caches on disk).

    Raises
    ------
    ValueError
        If ``energy.uses_gradient`` is False but Psi depends on G.
    """
    kernels = _CACHE.get(energy.key)
    if kernels is None:
        kernels = _CACHE[energy.key] = _compile(energy, comm)
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
    F : (2, 2)
        Deformation gradient.
    G : (2, 2, 2) or None
        ``G_ijk = dF_ij/dX_k``; None means 0 (ignored when the energy does not use G).
    params
        Parameter values (see :meth:`EnergyKernels.pack_constants`).

    Returns
    -------
    dict
        ``"psi"`` float; ``"P"`` (2, 2), ``"T"`` (2, 2, 2), ``"D"`` (2,)*4, ``"A"`` (2,)*5,
        ``"B"`` (2,)*6, indexed as in the module docstring; T, A, B are zero when the
        energy does not use G.
    """
    c = kernels.pack_constants(params)
    c[kernels.F_offset:kernels.F_offset + 4] = np.asarray(F, dtype=np.float64).reshape(SHAPES["P"]).ravel()
    if G is not None:
        c[kernels.G_offset:kernels.G_offset + 8] = np.asarray(G, dtype=np.float64).reshape(SHAPES["T"]).ravel()
    result = {name: np.zeros(shape) for name, shape in SHAPES.items()}
    for function, size, offsets in ((kernels.tangent, kernels.n_tangent, kernels.tangent_offsets),
                                    (kernels.residual, kernels.n_residual, kernels.residual_offsets)):
        out = tabulate(function, size, c)
        for name, start in offsets.items():
            result[name] = out[start:start + _size(name)].reshape(SHAPES[name])
    result["psi"] = float(result["psi"])
    return result
