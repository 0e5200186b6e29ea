"""The linear solver of the Newton steps: named presets and the rigid-body near-nullspace.

``"direct"`` (the default of :mod:`~dolfinx_sfvem.path_following.snes`) factorizes the tangent with MUMPS
(LDLᵀ, which also gives its inertia: the negative pivots of every step). Its cost grows fast
with the unknowns in 3D. ``"iterative"`` is GMRES preconditioned by a two-level p-multigrid:
Chebyshev/Jacobi smoothing on the degree-2 unknowns and MUMPS on the Galerkin projection of the
tangent onto the degree-1 space on the same mesh (the discretization's
:meth:`~dolfinx_sfvem.discretizations.discretization.Discretization.coarse_interpolation`, set by
:func:`configure_ksp`). Algebraic multigrid on the whole tangent (GAMG) stagnates with a third
medium: its regularization, a function of the second gradient, vanishes on the fields that are
linear per element, so these are near-null in the medium and must be on the coarse level.
It reports no inertia. Within Newton's iterations
GMRES stops at a relative tolerance of Eisenstat and Walker's choice (SNES's ``ksp_ew``: at most
1e-2, tightened as Newton's residual falls), outside them (the arc-length's bordering) at 1e-10.
Which one to take at which size: docs/guide/solving.md. The tangent carries the rigid-body
near-nullspace (:func:`rigid_body_modes`, 3 in 2D, 6 in 3D) for a GAMG chosen by options.
"""
from __future__ import annotations

import typing

import numpy as np
from petsc4py import PETSc

#: preset name -> PETSc options (keys without prefix); the problem's own options win over them
LINEAR_SOLVERS: dict[str, dict[str, str]] = {
    "direct": {},
    "iterative": {
        "ksp_type": "gmres",
        "ksp_gmres_restart": "100",
        "ksp_rtol": "1e-10",
        "snes_ksp_ew": "true",
        "snes_ksp_ew_rtol0": "0.01",
        "snes_ksp_ew_rtolmax": "0.01",
        "ksp_max_it": "1000",
        "pc_type": "mg",
        "pc_mg_galerkin": "both",
        "mg_levels_ksp_type": "chebyshev",
        "mg_levels_pc_type": "jacobi",
        "mg_levels_ksp_max_it": "3",
        "mg_coarse_ksp_type": "preonly",
        "mg_coarse_pc_type": "cholesky",
        "mg_coarse_pc_factor_mat_solver_type": "mumps",
    },
}


def linear_solver_options(name: str) -> dict[str, str]:
    """The PETSc options of the preset ``name`` (a key of :data:`LINEAR_SOLVERS`).

    Raises
    ------
    ValueError
        For an unknown name; the message lists the known ones.
    """
    if name not in LINEAR_SOLVERS:
        raise ValueError(f"unknown linear solver {name!r}; use one of {sorted(LINEAR_SOLVERS)}")
    return dict(LINEAR_SOLVERS[name])


def rigid_body_modes(x_nodes: np.ndarray, n_owned_nodes: int, create_vector: typing.Callable[[], PETSc.Vec]
                     ) -> PETSc.NullSpace:
    """The rigid-body displacements of the nodes as an orthonormal PETSc null space.

    Parameters
    ----------
    x_nodes : (n_local_nodes, d)
        Node positions (owned nodes first), d = 2 or 3.
    n_owned_nodes
        The number of owned nodes.
    create_vector
        Makes a vector of the unknowns' layout: block size d, local index ``d * node + component``.

    Returns
    -------
    PETSc.NullSpace
        d translations and d (d - 1) / 2 rotations, u = e_i and u = e_i x_j - e_j x_i about the
        centroid of the nodes (Gram-Schmidt orthonormalized, collective).
    """
    X = np.asarray(x_nodes[:n_owned_nodes], dtype=np.float64)
    d = X.shape[1]
    comm = create_vector().getComm().tompi4py()
    count = comm.allreduce(X.shape[0])
    centre = comm.allreduce(X.sum(axis=0)) / max(count, 1)
    fields = [np.eye(d)[i][None, :].repeat(X.shape[0], axis=0) for i in range(d)]
    for i in range(d):
        for j in range(i + 1, d):
            u = np.zeros_like(X)
            u[:, i], u[:, j] = -(X[:, j] - centre[j]), X[:, i] - centre[i]
            fields.append(u)
    basis: list[PETSc.Vec] = []
    for u in fields:
        v = create_vector()
        v.array[:] = u.reshape(-1)
        for w in basis:                                        # modified Gram-Schmidt
            v.axpy(-v.dot(w), w)
        v.scale(1.0 / v.norm())
        basis.append(v)
    return PETSc.NullSpace().create(vectors=basis, comm=comm)


def configure_ksp(ksp: PETSc.KSP, interpolation: PETSc.Mat) -> None:
    """Make the preconditioner of ``ksp`` the two-level p-multigrid of the ``"iterative"`` preset:
    the coarse space is the degree-1 one whose nodal values ``interpolation`` (n_fine x n_coarse,
    block size d) maps to the unknowns.

    Call it before ``ksp.setFromOptions()``, so that the levels read their options
    (``mg_levels_*``, ``mg_coarse_*``) and options that choose another preconditioner win.
    """
    pc = ksp.getPC()
    pc.setType(PETSc.PC.Type.MG)
    pc.setMGLevels(2)
    pc.setMGInterpolation(1, interpolation)
