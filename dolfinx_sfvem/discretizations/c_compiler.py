"""The C compiler of the package's JIT compiles: clang for FFCx 0.5's code, unless ``CC`` says otherwise.

FFCx writes a form's kernels as C and cffi compiles them with the compiler of Python's build
(``CC`` of ``sysconfig``: gcc on Debian and in most Python builds), or with the one the environment's
``CC`` names. FFCx 0.5 (DOLFINx 0.5) writes each quadrature point's pointwise work as one
straight-line block: some 45,000 intermediate values for the tangent of a third medium with a
rotation regularization on Q2 hexahedra. gcc 12 at -O2 spends about 4 CPU-minutes on that file,
most of them in register allocation; clang 14 at -O2 about 15 CPU-seconds. Both modules assemble
the same matrix, the Q2 tangent as fast, the P2 tangent in 1.2 times gcc's time. FFCx 0.11 writes
loops over the quadrature points instead, which gcc compiles faster than clang (docs/performance.md,
"Compiling the forms").

So, with FFCx 0.5, while the package compiles
(:func:`~dolfinx_sfvem.discretizations.compile_lock.compiling`), ``CC`` is set to the first of
:data:`CLANG_NAMES` on ``PATH``, then restored; a user who has set ``CC`` (``CC=gcc`` included) keeps
it, and without clang nothing changes. The compiler is not part of FFCx's module names: a cache
holds what either compiler built.
"""
from __future__ import annotations

import contextlib
import functools
import os
import shutil
import typing

import ffcx

#: whether FFCx writes straight-line code per quadrature point, which clang compiles much faster than gcc
STRAIGHT_LINE_KERNELS = ffcx.__version__.startswith("0.5.")
#: the clang executables looked for on PATH, in this order
CLANG_NAMES = ("clang", *(f"clang-{version}" for version in range(20, 13, -1)))


@functools.cache
def clang() -> str | None:
    """The path of the first of :data:`CLANG_NAMES` on ``PATH``, or None."""
    return next((path for path in map(shutil.which, CLANG_NAMES) if path is not None), None)


def jit_c_compiler() -> str | None:
    """The compiler :func:`c_compiler` sets ``CC`` to: None when ``CC`` is set, FFCx writes loops
    (:data:`STRAIGHT_LINE_KERNELS` False) or no clang is found."""
    return None if os.environ.get("CC") or not STRAIGHT_LINE_KERNELS else clang()


@contextlib.contextmanager
def c_compiler() -> typing.Iterator[None]:
    """``CC`` = :func:`jit_c_compiler` for the body when it is not None; the environment is restored after."""
    compiler = jit_c_compiler()
    if compiler is None:
        yield
        return
    previous = os.environ.get("CC")                    # None, or set but empty
    os.environ["CC"] = compiler
    try:
        yield
    finally:
        if previous is None:
            os.environ.pop("CC", None)
        else:
            os.environ["CC"] = previous
