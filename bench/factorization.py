"""What a symmetric factorization would pay: MUMPS LU against MUMPS LDL^T on the tangent.

Usage::

    python3 bench/factorization.py [--repeats 3] -- DEMO [demo options]

e.g. ``... -- multi_object --method vem --h 0.04 --steps 30``. The demo's problem is solved
along its load path (no output), then at the final state the tangent is assembled with the
solver's symmetric elimination of the Dirichlet conditions (constrained rows and columns zeroed,
1 on the diagonal: the matrix the solver factorizes) and, for comparison, with the constrained
rows and columns removed (K_ff, the free-free block). On both, each factorization is set up
``--repeats`` times (numeric factorization of a fresh PC each time, the smallest wall time kept):

- ``lu``: ``pc_type lu`` with MUMPS (the solver's option ``-pc_type lu``);
- ``ldlt``: ``pc_type cholesky`` with MUMPS, the matrix flagged symmetric, not positive
  definite (MUMPS SYM = 2, LDL^T with 1x1 and 2x2 pivots; the solver's default);

with, for LDL^T, the number of negative pivots (MUMPS INFOG(12)): the number of negative
eigenvalues of K_ff (Sylvester's law of inertia), i.e. of the tangent on the free unknowns.
Also: nonzeros per row, the symmetry defect ||K_ff - K_ff^T||_inf / ||K_ff||_inf. Prints and
writes JSON (``--json``); nothing is asserted.
"""
import argparse
import importlib
import json
import pathlib
import sys
import time
import typing

_BENCH = pathlib.Path(__file__).resolve().parent
sys.path[:0] = [str(_BENCH.parent / "demos"), str(_BENCH.parent)]

import numpy as np  # noqa: E402
from mpi4py import MPI  # noqa: E402
from petsc4py import PETSc  # noqa: E402

import _common as common  # noqa: E402

FACTORIZATIONS = {"lu": "lu", "ldlt": "cholesky"}


def free_block(A: PETSc.Mat, constrained_owned: np.ndarray) -> PETSc.Mat:
    """K_ff: the rows and columns of the free unknowns of A (owned mask ``constrained_owned``)."""
    start, _ = A.getOwnershipRange()
    free = PETSc.IS().createGeneral(start + np.flatnonzero(~constrained_owned).astype(PETSc.IntType),
                                    comm=A.getComm())
    return A.createSubMatrix(free, free)


def factorize(A: PETSc.Mat, kind: str, repeats: int) -> dict:
    """Smallest wall time of the numeric factorization of A by MUMPS (``kind`` lu or ldlt)."""
    best, negative = float("inf"), None
    for _ in range(repeats):
        pc = PETSc.PC().create(A.getComm())
        pc.setOperators(A)
        pc.setType(FACTORIZATIONS[kind])
        pc.setFactorSolverType("mumps")
        A.getComm().barrier()
        t0 = time.perf_counter()
        pc.setUp()
        best = min(best, A.getComm().tompi4py().allreduce(time.perf_counter() - t0, op=MPI.MAX))
        if kind == "ldlt":
            negative = int(pc.getFactorMatrix().getMumpsInfog(12))
        pc.destroy()
    return {"factorization_s": best, "negative_pivots": negative}


def symmetry_defect(A: PETSc.Mat) -> float:
    """||A - A^T||_inf / ||A||_inf."""
    D = A.copy()
    D.axpy(-1.0, A.transpose(PETSc.Mat()))
    return D.norm(PETSc.NormType.INFINITY) / A.norm(PETSc.NormType.INFINITY)


def measure(demo_argv: typing.Sequence[str], repeats: int) -> dict:
    name, argv = demo_argv[0], list(demo_argv[1:])
    demo = importlib.import_module(name)
    args = common.parse_args(demo.make_parser(), [*argv, "--quiet"])
    problem, _ = demo.build(args)
    result = problem.solve(args.steps, out=None)
    disc = problem.disc
    disc.set_constraints(problem.constraints().dofs)
    A = disc.create_matrix()
    problem.x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
    disc.jacobian(problem.x, A)                   # the constraints of the solve, eliminated symmetrically
    K = free_block(A, disc.constraints.mask[:disc.n_owned_dofs])
    for M in (A, K):
        M.setOption(PETSc.Mat.Option.SYMMETRIC, True)
        M.setOption(PETSc.Mat.Option.SPD, False)
    n, nnz = K.getSize()[0], K.getInfo(PETSc.Mat.InfoType.GLOBAL_SUM)["nz_used"]
    return {"demo": name, "argv": argv, "method": args.method, "load": float(result.load),
            "unknowns": int(disc.num_dofs_global), "free_unknowns": int(n), "nonzeros_per_row": nnz / n,
            "symmetry_defect": symmetry_defect(K),
            "lu_eliminated": factorize(A, "lu", repeats), "ldlt_eliminated": factorize(A, "ldlt", repeats),
            "lu": factorize(K, "lu", repeats), "ldlt": factorize(K, "ldlt", repeats)}


def main(argv: typing.Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    split = argv.index("--") if "--" in argv else len(argv)
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--json", type=pathlib.Path, default=None)
    args = p.parse_args(argv[:split])
    if split == len(argv):
        p.error("give the demo after --")
    record = measure(argv[split + 1:], args.repeats)
    record["ldlt_over_lu"] = record["ldlt"]["factorization_s"] / record["lu"]["factorization_s"]
    if MPI.COMM_WORLD.rank == 0:
        print(json.dumps(record, indent=1))
        if args.json is not None:
            args.json.write_text(json.dumps(record, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
