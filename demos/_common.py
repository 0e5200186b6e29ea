"""Command line and driver shared by the demos.

Every demo builds its parser with :func:`parser` (the options below), parses it with
:func:`parse_args`, builds a :class:`dolfinx_sfvem.ContactProblem` and hands it to
:func:`run`; its ``__main__`` block is ``sys.exit(exit_code(main))``.

Shared options
--------------
``--method`` (vem or fem: the P2 FEM reference on a triangle mesh of the same geometry with about
as many unknowns), ``--steps`` (the first load-factor increment is 1/steps), ``--max-increment``,
``--min-increment``, ``--fixed-increments``, ``--no-predictor`` (the load stepping of
:class:`~dolfinx_sfvem.path_following.stepping.LoadStepping`), ``--out``, ``--mesh`` (mesh variant), ``--h`` (mesh size),
``--gamma``, ``--alpha-r``, ``--regularization``, ``--beta`` (exp(-beta J) scaling of the
regularization, off unless given), ``--medium-quadrature`` (gauss; lobatto: the FEM integrates
the medium at its Q2 nodes; reduced: at the degree-2 Gauss points of its P2 simplices), ``--gamma-start`` (continuation in gamma from this value,
:mod:`dolfinx_sfvem.path_following.gamma_continuation`), ``--quiet``, ``--resume DIR`` (continue the stopped run
whose outputs are in DIR from its last converged step; give the same options as that run), ``--adapt [J]``
(SFVEM: refine the medium during the path where J < J, default 0.8, with ``--adapt-levels`` and
``--adapt-max-unknowns`` as limits; docs/refinement-local.md). Every other argument starting with a
single ``-`` is a PETSc option of the library's solvers, with their prefix ``tmc_``
(``-tmc_snes_monitor``, ``-tmc_ksp_type gmres``, ``-tmc_pc_factor_mat_solver_type superlu_dist``, ...);
it goes to the solve's ``petsc_options``, never to PETSc's global options database.

Exit codes
----------
0 the load path was completed; 1 it was not (the converged steps are kept in the output
directory); 2 invalid input (argparse errors, or a ``ValueError`` / ``SolveFailed`` raised by
the library), reported on stderr without a traceback; 3 any other exception, reported on stderr
with its traceback and a last line naming it and where it was raised (in a parallel run by
the ranks that raised it, and then every rank is ended: ``MPI_Abort``, as a rank that raised
alone would leave the others waiting in a collective call forever); 130 a second Ctrl-C and 143
a second SIGTERM (a batch scheduler's notice before it kills), which interrupt the step under way
(the first stops the path after it): one line on stderr, the converged steps kept.
"""
from __future__ import annotations

import argparse
import csv
import math
import pathlib
import signal
import sys
import threading
import time
import traceback
import typing

import numpy as np
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem.output import last_word
from dolfinx_sfvem.path_following.interrupt import interrupt_in, raise_interrupted, signal_of
from dolfinx_sfvem.path_following.snes import DEFAULT_PREFIX, options_from_tokens
from dolfinx_sfvem.physics.energy import QUADRATURES

METHODS = ("vem", "fem")
REGULARIZATIONS = ("huhu", "huhu_lulu", "rotation", "tan_rotation")


# --------------------------------------------------------------------------- argument types
def _number(kind: type, accept: typing.Callable[[float], bool], requirement: str) -> typing.Callable[[str], float]:
    """An argparse ``type`` parsing a finite ``kind`` that satisfies ``accept``."""
    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {requirement}, got {text!r}") from None
        if not (math.isfinite(value) and accept(value)):
            raise argparse.ArgumentTypeError(f"must be {requirement}, got {text}")
        return value
    return parse


positive_int = _number(int, lambda v: v >= 1, "an integer >= 1")
finite_float = _number(float, lambda v: True, "a finite number")
positive_float = _number(float, lambda v: v > 0, "a number > 0")
non_negative_float = _number(float, lambda v: v >= 0, "a number >= 0")


class _Parser(argparse.ArgumentParser):
    """ArgumentParser that prints help and errors on MPI rank 0 only."""

    def _print_message(self, message: str, file=None) -> None:
        if MPI.COMM_WORLD.rank == 0:
            super()._print_message(message, file)


# --------------------------------------------------------------------------- command line
def parser(name: str, description: str, *, steps: int = 50, meshes: typing.Sequence[int] = (1,),
           mesh_help: str = "mesh variant", h: float = 0.05, h_max: float = math.inf, gamma: float = 1e-5,
           alpha_r: float = 1.0, regularization: str = "rotation",
           beta: float | None = None) -> argparse.ArgumentParser:
    """The parser with the options every demo shares; a demo adds its own to it.

    Parameters
    ----------
    name
        Demo name; the default output directory is ``out/<name>``.
    description
        Shown by ``--help`` (the demo's docstring).
    steps, meshes, h, gamma, alpha_r, regularization, beta
        The demo's defaults; ``meshes`` lists the valid ``--mesh`` variants, the first is the
        default; ``beta`` None means the exp(-beta J) scaling is off unless ``--beta`` is given.
    h_max
        Largest accepted ``--h`` (a mesh must resolve the thinnest part of the geometry).
    mesh_help
        What ``--mesh`` selects in this demo.
    """
    p = _Parser(prog=f"{name}.py", description=description, allow_abbrev=False,
                formatter_class=argparse.RawDescriptionHelpFormatter,
                epilog=f"Arguments starting with a single '-' are PETSc options of the library's solvers, with their "
                       f"prefix {DEFAULT_PREFIX!r} (e.g. -{DEFAULT_PREFIX}snes_monitor -{DEFAULT_PREFIX}ksp_type gmres).")
    p.add_argument("--method", choices=METHODS, default=METHODS[0], help="discretization (default %(default)s)")
    p.add_argument("--steps", type=positive_int, default=steps,
                   help="the first load-factor increment is 1/steps; the increments then adapt to the Newton "
                        "iterations, at most --max-increment (default %(default)s)")
    p.add_argument("--max-increment", type=_number(float, lambda v: 0 < v <= 1, "a number in (0, 1]"), default=None,
                   help="largest load-factor increment (default max(1/steps, 0.1): at least 10 points on the path)")
    p.add_argument("--min-increment", type=positive_float, default=None,
                   help="smallest load-factor increment of the automatic cut-back, <= 1/steps "
                        "(default (1/steps)/2^10)")
    p.add_argument("--fixed-increments", action=argparse.BooleanOptionalAction, default=False,
                   help="every increment 1/steps (halved when a step fails) instead of increments that adapt to "
                        "the Newton iterations")
    p.add_argument("--predictor", action=argparse.BooleanOptionalAction, default=True,
                   help="start each step from the secant extrapolation of the last two converged states "
                        "(default: yes)")
    p.add_argument("--out", type=pathlib.Path, default=pathlib.Path("out") / name,
                   help="output directory (default %(default)s)")
    p.add_argument("--mesh", type=int, choices=tuple(meshes), default=meshes[0],
                   help=f"{mesh_help} (default %(default)s)")
    h_range = "a number > 0" if h_max == math.inf else f"a number in (0, {h_max:g}]"
    p.add_argument("--h", type=_number(float, lambda v: 0 < v <= h_max, h_range), default=h,
                   help=f"mesh size, {h_range} (default %(default)s)")
    p.add_argument("--gamma", type=positive_float, default=gamma,
                   help="third-medium scaling gamma > 0 (default %(default)s)")
    p.add_argument("--alpha-r", type=non_negative_float, default=alpha_r,
                   help="regularization weight alpha_r >= 0 (default %(default)s)")
    p.add_argument("--regularization", choices=REGULARIZATIONS, default=regularization,
                   help="regularization of the medium, paper Table 1 (default %(default)s)")
    p.add_argument("--beta", type=non_negative_float, default=beta,
                   help="exponent of the exp(-beta J) scaling of the regularization "
                        f"(default {'off' if beta is None else '%(default)s'})")
    p.add_argument("--beta1", type=non_negative_float, default=None,
                   help="weight of the medium's skew penalty beta1/2 |w(F)|^2, not scaled by gamma (the local part of "
                        "Wriggers et al. 2025's rotation regularization; docs/guide/medium.md; default: none)")
    p.add_argument("--medium-quadrature", choices=QUADRATURES, default=QUADRATURES[0],
                   help="where the medium's energy is integrated: its Gauss points; 'lobatto': the Gauss-Lobatto "
                        "points, which are the nodes of Q2 cells (--method fem on quadrilaterals or hexahedra only); "
                        "'reduced': the degree-2 Gauss points of P2 triangles and tetrahedra (--method fem only) "
                        "(docs/guide/medium.md; default %(default)s)")
    p.add_argument("--gamma-start", type=positive_float, default=None, metavar="G0",
                   help="continuation in gamma: the medium starts the path at G0 and its gamma falls "
                        "log-linearly with the load factor to --gamma at the full load (e.g. 1e-5 for "
                        "--gamma 1e-6; docs/guide/medium.md; default: off)")
    p.add_argument("--fem-jump-penalty", type=positive_float, default=None, metavar="ETA",
                   help="--method fem only: add C0 interior-penalty terms with penalty ETA on the medium's "
                        "interior facets (dolfinx_sfvem/discretizations/fem.py; e.g. 40; default: none, as the paper's model)")
    p.add_argument("--quiet", action="store_true", help="no progress output, only the final lines")
    p.add_argument("--pressure-at", type=positive_float, nargs="+", default=(), metavar="LOAD",
                   help="also plot the contact pressure at these load factors "
                        "(contact_pressure_<load>.png; the last state's is always plotted)")
    p.add_argument("--resume", type=pathlib.Path, default=None, metavar="DIR",
                   help="continue the stopped run in DIR from its last converged step (same options as that run)")
    p.add_argument("--adapt", type=_number(float, lambda v: 0 < v < 1, "a number in (0, 1)"), nargs="?",
                   const=sf.Compression().J_below, default=None, metavar="J",
                   help="--method vem only: refine the medium during the load path where it is compressed "
                        "below J (default J %(const)s when given without a value)")
    p.add_argument("--adapt-levels", type=positive_int, default=2, metavar="N",
                   help="with --adapt: split a polygon at most N times (default %(default)s)")
    p.add_argument("--adapt-max-unknowns", type=positive_int, default=None, metavar="N",
                   help="with --adapt: no refinement beyond N unknowns (default: no limit)")
    return p


def adaptivity(args: argparse.Namespace) -> sf.Adaptivity | None:
    """The adaptive refinement of ``--adapt`` (None without it)."""
    if args.adapt is None:
        return None
    return sf.Adaptivity(sf.Compression(args.adapt), max_levels=args.adapt_levels,
                         max_unknowns=args.adapt_max_unknowns)


def add_uy(p: argparse.ArgumentParser, default: float, where: str, note: str = "") -> None:
    """``--uy``: the prescribed vertical displacement of ``where`` at load factor 1."""
    p.add_argument("--uy", type=finite_float, default=default,
                   help=f"vertical displacement of {where} (default %(default)s{note})")


def add_both(p: argparse.ArgumentParser) -> None:
    """``--both``: run SFVEM and FEM one after the other (:func:`methods`)."""
    p.add_argument("--both", action="store_true", help="run SFVEM and FEM and plot them together")


def methods(args: argparse.Namespace) -> tuple[str, ...]:
    """The methods to run: both with ``--both``, else ``--method``."""
    return METHODS if args.both else (args.method,)


def sub_run(args: argparse.Namespace, method: str, out: pathlib.Path) -> argparse.Namespace:
    """The arguments of one of several runs of a demo: ``method``, written to (or resumed from,
    with ``--resume``) ``out``."""
    return argparse.Namespace(**{**vars(args), "method": method, "out": out,
                                 "resume": out if args.resume is not None else None})


def parse_args(p: argparse.ArgumentParser, argv: typing.Sequence[str] | None = None) -> argparse.Namespace:
    """Parse the command line; PETSc options (prefix ``tmc_``) stay as tokens in
    ``args.petsc_options`` (recorded in summary.json) and go to the solve (:func:`run`).

    Unknown ``--options``, stray positional arguments and ``--fem-NAME`` options without
    ``--method fem`` are errors (exit code 2).
    """
    args, rest = p.parse_known_args(argv)
    for k, token in enumerate(rest):
        if token.startswith("--"):
            p.error(f"unrecognized argument {token!r} (PETSc options start with a single '-')")
        if not _is_option_name(token) and (k == 0 or not _is_option_name(rest[k - 1])):
            p.error(f"unexpected argument {token!r} (not the value of a PETSc option)")
    if args.method != "fem":                         # every --fem-NAME option a demo defines
        for name, value in vars(args).items():
            if name.startswith("fem_") and value is not None:
                p.error(f"--{name.replace('_', '-')} needs --method fem")
    if args.adapt is not None and (args.method != "vem" or args.resume is not None):
        p.error("--adapt needs --method vem and cannot be combined with --resume")
    try:
        options_from_tokens(rest, DEFAULT_PREFIX)
    except ValueError as err:
        p.error(str(err))
    args.petsc_options = rest
    if args.resume is not None:
        args.out = args.resume
    if args.out.exists() and not args.out.is_dir():
        p.error(f"--out {args.out}: exists and is not a directory")
    return args


def _is_option_name(token: str) -> bool:
    """``-name`` but not a negative number (which is an option's value)."""
    try:
        float(token)
    except ValueError:
        return token.startswith("-")
    return False


def discretization(args: argparse.Namespace) -> dict:
    """Keyword arguments of :class:`~dolfinx_sfvem.ContactProblem` from the command line
    (``--method``, ``--quiet``, ``--fem-jump-penalty``)."""
    options = {"method": args.method, "verbose": not args.quiet}
    if args.fem_jump_penalty is not None:
        options["jump_penalty"] = args.fem_jump_penalty
    return options


def third_medium(args: argparse.Namespace, mu: float, K: float = 0.0) -> sf.ThirdMedium:
    """The third medium of shear modulus ``mu`` and bulk modulus ``K`` with the command line's
    ``--gamma --alpha-r --regularization --beta --medium-quadrature --beta1``."""
    return sf.ThirdMedium(mu=mu, K=K, gamma=args.gamma, alpha_r=args.alpha_r, regularization=args.regularization,
                          beta=args.beta, quadrature=args.medium_quadrature, beta1=args.beta1)


# --------------------------------------------------------------------------- markers and observers
def at_point(xy: typing.Sequence[float], tol: float = 1e-10) -> typing.Callable[[np.ndarray], np.ndarray]:
    """Marker of the nodes at the point ``xy`` (2 or 3 coordinates; a 2D point ignores z)."""
    point = np.asarray(xy, dtype=np.float64)[:, None]
    return lambda x: np.linalg.norm(x[:point.shape[0]] - point, axis=0) <= tol


def on_segment(a: typing.Sequence[float], b: typing.Sequence[float],
               tol: float = 1e-10) -> typing.Callable[[np.ndarray], np.ndarray]:
    """Marker of the nodes on the straight segment from ``a`` to ``b``."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)

    def marker(x: np.ndarray) -> np.ndarray:
        p = x[:2].T
        s = np.clip((p - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
        return np.linalg.norm(p - (a + s[:, None] * (b - a)), axis=1) <= tol
    return marker


def displacement_observer(problem: sf.ContactProblem, marker: typing.Callable[[np.ndarray], np.ndarray],
                          component: int) -> typing.Callable[[sf.ContactProblem], float]:
    """Observer returning displacement component ``component`` at the one node selected by ``marker``.

    Raises
    ------
    ValueError
        If the marker does not select exactly one node.
    """
    def owned_dof(disc: sf.Discretization) -> np.ndarray:
        dofs = disc.locate_dofs(marker, component=component)
        owned = dofs[dofs < disc.n_owned_dofs]
        count = problem.comm.allreduce(owned.size, op=MPI.SUM)
        if count != 1:
            raise ValueError(f"a displacement observer needs exactly one node, the marker selects {count}")
        return owned
    located = {"disc": problem.disc, "dof": owned_dof(problem.disc)}

    def observe(p: sf.ContactProblem) -> float:
        if p.disc is not located["disc"]:                  # refined since: the node has another DOF
            located.update(disc=p.disc, dof=owned_dof(p.disc))
        with p.x.localForm() as xl:
            return p.comm.allreduce(float(xl.array_r[located["dof"]].sum()), op=MPI.SUM)
    return observe


# --------------------------------------------------------------------------- driver
def run(problem: sf.ContactProblem, args: argparse.Namespace,
        observers: typing.Mapping[str, typing.Callable[[sf.ContactProblem], float]] | None = None,
        **solve_options) -> int:
    """Solve the load path, write the outputs to ``args.out`` and report.

    The command-line arguments (except ``--out``, ``--quiet``, ``--resume``, ``--pressure-at``,
    and the ``--adapt`` options when it is not given) are stored in the "parameters" of summary.json. ``solve_options``
    (e.g. ``min_increment``, or a ``control``, which then replaces ``--steps``) go to
    :meth:`~dolfinx_sfvem.ContactProblem.solve`.

    Returns
    -------
    int
        Exit code: 0 if the full load was reached, 1 otherwise.
    """
    adapt_options = ("adapt", "adapt_levels", "adapt_max_unknowns") if args.adapt is None else ()
    unset = adapt_options + (("gamma_start",) if args.gamma_start is None else ())   # earlier runs' identity
    problem.parameters.update({k: v for k, v in vars(args).items()
                               if k not in ("out", "quiet", "resume", "pressure_at", *unset)})
    control = solve_options.pop("control", None) or load_stepping(args)
    result = problem.solve(control=control, out=args.out, observers=observers, resume=args.resume is not None,
                           pressure_at=args.pressure_at, adapt=adaptivity(args),
                           petsc_options=petsc_options(args), gamma_start=args.gamma_start, **solve_options)
    if problem.comm.rank == 0:
        files = sorted(f.name for f in args.out.iterdir() if not f.name.startswith("."))
        print(f"outputs in {args.out}/: {', '.join(files)}")
        unstable = " (UNSTABLE final state: not an answer)" if result.stable is False else ""
        print(f"load reached {result.load:.6g} of 1 | converged: {'yes' if result.converged else 'no'}{unstable} | "
              f"wall time: {result.wall_time_s:.1f} s | dofs: {result.summary['dofs']}", flush=True)
    return 0 if result.converged else 1


def load_stepping(args: argparse.Namespace) -> sf.LoadStepping:
    """The load stepping of ``--steps``, ``--min-increment``, ``--max-increment``, ``--fixed-increments``
    and ``--predictor``."""
    return sf.LoadStepping(args.steps, min_increment=args.min_increment, max_increment=args.max_increment,
                           adaptive=not args.fixed_increments, predictor=args.predictor)


def petsc_options(args: argparse.Namespace) -> dict[str, str]:
    """The PETSc options of the command line, keyed without the prefix."""
    return options_from_tokens(args.petsc_options, DEFAULT_PREFIX)


def read_load_path(path: pathlib.Path) -> list[dict[str, float]]:
    """The rows of load_path.csv as floats (empty if the file is missing); an empty field (a value
    not recorded, e.g. the negative pivots of an iterative linear solver) is NaN."""
    if not path.exists():
        return []
    with open(path, newline="") as f:
        return [{k: float(v) if v != "" else math.nan for k, v in row.items()} for row in csv.DictReader(f)]


#: exit code of a run ended by an unexpected exception (module docstring)
CRASHED = 3
#: exit code of a run interrupted at once by a second Ctrl-C (128 + SIGINT, as a shell reports it);
#: by a second SIGTERM: 128 + SIGTERM
INTERRUPTED = 128 + signal.SIGINT
#: seconds a rank waits between its last message and ``MPI_Abort``: MPICH's launcher tears its
#: output forwarding down on the abort, and a message still in the pipe was lost in 2 of 5 runs
ABORT_GRACE = 0.5


def exit_code(main: typing.Callable[[typing.Sequence[str] | None], int],
              argv: typing.Sequence[str] | None = None) -> int:
    """Run a demo's ``main(argv)`` with :mod:`~dolfinx_sfvem.output.last_word` armed (a library that ends
    the process with ``exit()`` still leaves a message); expected failures become a message on stderr and exit code 2,
    any other exception its traceback and :func:`crash_message` on stderr and exit code
    :data:`CRASHED`; a second Ctrl-C or SIGTERM (the first stops the path after its step), or
    one outside the load path, a one-line message and exit code 128 + the signal's number
    (:data:`INTERRUPTED` for Ctrl-C; the load path has already said what it kept). In parallel
    all of them end every rank through ``MPI_Abort`` (an error raised on one rank alone would leave
    the others waiting in a collective), and each rank that raised names itself."""
    comm = MPI.COMM_WORLD
    last_word.arm()
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, raise_interrupted)     # the load path's StopRequest takes over during it
    try:
        return main(argv)
    except KeyboardInterrupt as err:
        return _interrupted(comm, err)
    except Exception as err:
        if (interrupt := interrupt_in(err)) is not None:       # wrapped by the code it interrupted
            return _interrupted(comm, interrupt)
        if isinstance(err, (ValueError, sf.SolveFailed)):
            return _end(comm, f"error: {err}", 2)
        traceback.print_exc()
        return _end(comm, crash_message(err), CRASHED)


def _interrupted(comm: MPI.Comm, interrupt: KeyboardInterrupt) -> int:
    """:func:`_end` of a run interrupted by a signal: exit code 128 + its number."""
    signum = signal_of(interrupt)
    return _end(comm, f"interrupted by signal {signum} ({signal.Signals(signum).name})", 128 + signum)


def _end(comm: MPI.Comm, text: str, code: int) -> int:
    """``text`` on stderr, prefixed by the rank in a parallel run, where every rank is then ended
    with ``code`` (``MPI_Abort``); ``code`` otherwise."""
    rank = f"rank {comm.rank} of {comm.size}: " if comm.size > 1 else ""
    print(f"{rank}{text}", file=sys.stderr, flush=True)
    if comm.size > 1:
        last_word.disarm()
        time.sleep(ABORT_GRACE)
        comm.Abort(code)
    return code


def crash_message(err: BaseException) -> str:
    """``error: <type> in <file>:<line> (<function>): <message>``, where ``err`` was raised (its
    innermost frame)."""
    frames = traceback.extract_tb(err.__traceback__)
    where = f" in {frames[-1].filename}:{frames[-1].lineno} ({frames[-1].name})" if frames else ""
    return f"error: {type(err).__name__}{where}: {err}"
