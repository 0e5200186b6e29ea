"""The files of a run, written as it goes, and resuming a stopped run from them.

A run directory holds ``summary.json`` (:meth:`~dolfinx_sfvem.path_following.load_path.LoadPath.summary`),
``load_path.csv``, ``displacement.xdmf``/``.h5`` (the displacement ``u`` and the contact pressure
:data:`PRESSURE_FIELD` of every converged step), the same fields in the VTX series
``displacement.bp`` where DOLFINx has ADIOS2 (:class:`VTXSeries`) and :data:`CHECKPOINT`; all but
the XDMF pair and the VTX series are rewritten atomically after every converged step, so a run
killed at any moment leaves a consistent directory that ``solve(..., resume=True)`` continues
(docs/architecture.md).
"""
from __future__ import annotations

import itertools
import json
import logging
import pathlib
import typing
from dataclasses import dataclass

import numpy as np
import scipy.spatial

from mpi4py import MPI
from petsc4py import PETSc

from dolfinx_sfvem import _compat
from dolfinx_sfvem.output import post
from dolfinx_sfvem.output.logs import warn
from dolfinx_sfvem.physics.contact import ContactPressure
from dolfinx_sfvem.discretizations.discretization import Discretization
from dolfinx_sfvem.output.run_summary import RUNNING, StepRecord
from dolfinx_sfvem.path_following.stepping import Control

log = logging.getLogger(__name__)

#: load factors closer than this count as equal (a step's load against a requested one)
LOAD_TOL = 1e-9

#: state of the last converged step: node ``keys`` (k,), nodal ``values`` (k, 2), the control's
#: state (``control_load``, ``control_increment``, ...) and its ``previous`` state (k, 2) if it keeps one
CHECKPOINT = "checkpoint.npz"
#: first bytes of every HDF5 file (its superblock signature)
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
#: name of the contact pressure's field in the XDMF series (beside the displacement ``u``)
PRESSURE_FIELD = "contact_pressure"
#: summary.json entries that may differ between a stopped run and its resumption
_RUN_ENTRIES = ("wall_time_s", "converged", "stable", "message", "newton", "steps", "ranks")


def problem_identity(summary: typing.Mapping[str, typing.Any]) -> dict[str, typing.Any]:
    """What identifies the problem of a summary (everything but the run's progress and the
    PETSc options), flattened to ``{"parameters.uy": -0.3, ...}`` and normalised through JSON."""
    data = json.loads(json.dumps({k: v for k, v in summary.items() if k not in _RUN_ENTRIES},
                                 default=post.json_default))
    data.get("parameters", {}).pop("petsc_options", None)
    flat: dict[str, typing.Any] = {}

    def walk(prefix: str, value: typing.Any) -> None:
        if isinstance(value, dict):
            for k, v in value.items():
                walk(f"{prefix}.{k}" if prefix else str(k), v)
        else:
            flat[prefix] = value
    walk("", data)
    return flat


def differences(saved: typing.Mapping[str, typing.Any], now: typing.Mapping[str, typing.Any]) -> list[str]:
    """``"name: saved A, now B"`` for every entry that differs."""
    return [f"{k}: saved {saved.get(k, 'nothing')!r}, now {now.get(k, 'nothing')!r}"
            for k in sorted(set(saved) | set(now)) if saved.get(k) != now.get(k)]


@dataclass
class Checkpoint:
    """What a stopped run left to continue from (:func:`read_checkpoint`).

    Attributes
    ----------
    keys : (k,) int64
        Node keys (:meth:`Discretization.get_state`) of the whole mesh.
    values : (k, 2)
        Displacement of every node [length].
    control : dict
        The control's state (:meth:`~dolfinx_sfvem.path_following.stepping.Control.state`).
    previous : (k, 2) or None
        The control's previous converged state (:attr:`~dolfinx_sfvem.path_following.stepping.Control.previous`).
    records : list of dict
        The converged steps of summary.json.
    wall_time_s : float
        Wall time of the stopped run [s] (0 when not finite).
    """
    keys: np.ndarray
    values: np.ndarray
    control: dict[str, float]
    previous: np.ndarray | None
    records: list[dict]
    wall_time_s: float


#: prefix of the control's state entries in :data:`CHECKPOINT`
CONTROL_PREFIX = "control_"


def read_checkpoint(out: pathlib.Path, summary_now: typing.Mapping[str, typing.Any]) -> Checkpoint:
    """The checkpoint of the run in ``out``, which must have solved the problem of ``summary_now``
    with the same control (ValueError naming what differs otherwise)."""
    path = out / CHECKPOINT
    if not path.exists():
        raise ValueError(f"cannot resume: {path} does not exist")
    data = np.load(path)
    with open(out / "summary.json") as f:
        previous = json.load(f)
    differing = differences(problem_identity(previous), problem_identity(summary_now))
    if differing:
        raise ValueError(f"cannot resume the run in {out}: it solved another problem ({'; '.join(differing)}); "
                         "resuming continues the same problem only, start a new run (another output "
                         "directory) to change it")
    earlier = previous.get("wall_time_s")
    control = {k[len(CONTROL_PREFIX):]: float(data[k]) for k in data.files if k.startswith(CONTROL_PREFIX)}
    return Checkpoint(data["keys"], data["values"], control, data["previous"] if "previous" in data.files else None,
                      [r for r in previous["steps"] if r["converged"]],
                      float(earlier) if isinstance(earlier, (int, float)) and np.isfinite(earlier) else 0.0)


def progress_line(rec: StepRecord) -> str:
    """One line per converged step: Newton, J, gap, negative pivots of the tangent (when any;
    UNSTABLE when they make the state an unstable equilibrium, :mod:`~dolfinx_sfvem.path_following.stability`),
    time, the first prescribed condition's reaction and the first load's magnitude and
    work-conjugate displacement (the full record is in summary.json and load_path.csv)."""
    res = rec.residual_norms[-1] if rec.residual_norms else float("nan")
    gap = rec.gap["value"] if rec.gap and rec.gap["value"] is not None else float("inf")
    kinked = f"  kinked {rec.kinked_elements}" if rec.kinked_elements else ""
    if rec.stable is False:
        kinked += f"  UNSTABLE ({rec.negative_pivots} negative pivot{'' if rec.negative_pivots == 1 else 's'})"
    elif rec.negative_pivots:
        kinked += f"  negative pivots {rec.negative_pivots}"
    loaded = [(n, v) for n, v in rec.reaction.items() if n != "fixed"]
    reaction = f"  R[{loaded[0][0]}] ({', '.join(f'{r:+.4e}' for r in loaded[0][1])})" if loaded else ""
    load = next(iter(rec.loads.items()), None)
    load = f"  {load[0]} {load[1]['magnitude']:+.4e} at {load[1]['displacement']:+.4e}" if load else ""
    return (f"step {rec.step:4d}  load {rec.load:8.5f}  newton {rec.newton_iterations:2d}  |R| {res:.2e}  "
            f"min J {rec.min_J:.3f}  gap {gap:+.3e}{kinked}  {rec.wall_time_s:6.2f} s  dofs {rec.dofs}{reaction}{load}")


def nodes_at(X: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The row of ``X`` (n, d) at each of ``points`` (m, >= d; their first d coordinates), -1 where
    no row is within 1e-9 of X's extent (a k-d tree query)."""
    X = np.asarray(X, dtype=float)
    if X.shape[0] == 0:
        return np.full(points.shape[0], -1, dtype=np.int64)
    tolerance = 1e-9 * max(float(np.ptp(X, axis=0).max()), 1e-300)
    distance, row = scipy.spatial.cKDTree(X).query(points[:, :X.shape[1]], distance_upper_bound=tolerance)
    return np.where(np.isfinite(distance), row, -1).astype(np.int64)


class PressureField:
    """The contact pressure as a field of the output mesh, for the XDMF series: of ``degree`` (1, or
    2 on a mesh of curved cells, whose XDMF fields have the geometry's degree) on ``mesh``
    (``Discretization.dolfinx_mesh``), named :data:`PRESSURE_FIELD`; at the nodes that are boundary
    nodes of the solids their nodal pressure (:attr:`ContactPressure.pressure`), 0 elsewhere (for
    degree 1 the degree-2 nodes between them are left out, as in the displacement's series).
    The same for 2D boundaries and 3D surfaces: the vertices are matched to the nodes by
    reference position (:attr:`ContactPressure.X`), once per mesh.

    Attributes
    ----------
    function : dolfinx.fem.Function
        The field (scalar, of ``degree``), set by :meth:`set`.
    """

    def __init__(self, mesh, degree: int = 1):
        import dolfinx.fem
        self.function = dolfinx.fem.Function(_compat.scalar_function_space(mesh, degree), name=PRESSURE_FIELD)
        self._rows: np.ndarray | None = None          # the row of ContactPressure.X at each local dof

    def set(self, pressure: ContactPressure) -> "dolfinx.fem.Function":
        """:attr:`function` from ``pressure`` (the same on every rank; not collective)."""
        if self._rows is None:
            self._rows = nodes_at(pressure.X, self.function.function_space.tabulate_dof_coordinates())
        found = self._rows >= 0
        values = self.function.x.array
        values[:] = 0.0
        values[found] = pressure.pressure[self._rows[found]]
        return self.function


class VTXSeries:
    """The displacement ``u`` and the contact pressure :data:`PRESSURE_FIELD` of every converged
    step in an ADIOS2 directory (VTX, for ParaView) beside the XDMF pair. ``u`` is written at its own
    degree (P2, or Q2 on hexahedra: no interpolation to degree 1 as in the XDMF series), the
    pressure interpolated into the scalar space of the same degree (exact: its degree-1 field is
    in it; VTX writes fields of one element only). Only where DOLFINx was built with ADIOS2
    (:func:`._compat.has_vtx`: the 0.11 wheel, not Debian's 0.5.2); elsewhere nothing is written
    and that is logged once per process.

    Parameters
    ----------
    comm
        The run's communicator (collective).
    path
        The ``.bp`` directory (replaced if it exists).
    u
        The displacement, a vector P2 function of the output mesh (:meth:`Discretization.output_function`).

    Attributes
    ----------
    path : pathlib.Path
    """
    _unavailable_logged = False

    def __init__(self, comm: MPI.Comm, path: pathlib.Path, u):
        import dolfinx.fem
        self.path = path
        self.writer = None
        if not _compat.has_vtx():
            if not VTXSeries._unavailable_logged and comm.rank == 0:
                log.info(f"no VTX series ({path.name}): DOLFINx {_compat.DOLFINX_VERSION} was built without "
                         "ADIOS2 (dolfinx.io.VTXWriter); the XDMF series has the same fields")
            VTXSeries._unavailable_logged = True
            return
        self.pressure = dolfinx.fem.Function(_compat.scalar_function_space(u.function_space.mesh, 2),
                                             name=PRESSURE_FIELD)
        self.writer = _compat.vtx_writer(comm, path, [u, self.pressure])

    def write(self, load: float, pressure) -> None:
        """Append a step at load factor ``load`` (the current ``u``; ``pressure`` the degree-1
        :attr:`PressureField.function`). Collective."""
        if self.writer is None:
            return
        self.pressure.interpolate(pressure)
        self.writer.write(load)

    def close(self) -> None:
        """Close the directory (its steps stay readable; collective)."""
        if self.writer is not None:
            self.writer.close()
            self.writer = None


def _first_bytes(path: pathlib.Path, n: int) -> bytes:
    with open(path, "rb") as f:
        return f.read(n)


class RunWriter:
    """Writes the outputs of a run as it goes (every converged step) and at its end.

    Parameters
    ----------
    comm
        The run's communicator.
    disc, x
        The discretization and state of the current mesh (:meth:`new_mesh` after a refinement).
    out
        The output directory.
    control
        The path's control (its state goes into the checkpoint).
    summary
        ``summary(records, wall, converged, message)``: the content of summary.json.
    append
        Continue the XDMF series of a stopped run.
    pressure_at
        Load factors at which the contact pressure is plotted (:meth:`step`).
    """

    def __init__(self, comm: MPI.Comm, disc: Discretization, x: PETSc.Vec, out: str | pathlib.Path,
                 control: Control, summary: typing.Callable[..., dict], append: bool = False,
                 pressure_at: typing.Iterable[float] = ()):
        self.comm = comm
        self.control = control
        self.summary = summary
        #: load factors whose contact pressure is still to be plotted (at the first converged step
        #: that reaches each); those a resumed run has passed already are dropped
        self.pressure_at = sorted(t for t in pressure_at if t > control.load + LOAD_TOL)
        self.out = pathlib.Path(out)
        if comm.rank == 0:
            self.out.mkdir(parents=True, exist_ok=True)
        comm.barrier()
        self.meshes = 0                    # refinements during the run (:meth:`new_mesh`)
        self.xdmf_path = self.out / "displacement.xdmf"
        self.append = append
        self.vtx: VTXSeries | None = None
        self.new_mesh(disc, x)
        self.xdmf_started = append and self._readable_xdmf()

    def new_mesh(self, disc: Discretization, x: PETSc.Vec) -> None:
        """Output functions on the discretization ``disc`` with state ``x``; after a refinement
        during the run the displacement series goes on in ``displacement_refined<k>.xdmf``,
        k = 1, 2, ... (one XDMF file per mesh), and the VTX series likewise (:meth:`_vtx_path`)."""
        import dolfinx.fem
        self.disc, self.x = disc, x
        self.u_p2 = disc.output_function(x)
        # XDMF writes fields at the geometry's degree: 1, or 2 on curved cells
        degree = _compat.mesh_geometry_degree(disc.dolfinx_mesh)
        self.u_p1 = dolfinx.fem.Function(_compat.vector_function_space(disc.dolfinx_mesh, degree), name="u")
        self.pressure = PressureField(disc.dolfinx_mesh, degree)
        if self.meshes:
            self.xdmf_path = self.out / f"displacement_refined{self.meshes}.xdmf"
        if self.vtx is not None:
            self.vtx.close()
        self.vtx = VTXSeries(self.comm, self._vtx_path(resumed=self.append and not self.meshes), self.u_p2)
        self.meshes += 1
        self.xdmf_started = False

    def _vtx_path(self, resumed: bool) -> pathlib.Path:
        """The VTX directory beside the XDMF file: ``displacement.bp`` (``displacement_refined<k>.bp``
        after a refinement); a resumed run cannot append to the stopped run's series (DOLFINx's
        writer only creates) and starts ``displacement_resumed<n>.bp``, n = 1, 2, ... the first
        that does not exist."""
        path = self.xdmf_path.with_suffix(".bp")
        if resumed:
            n = None
            if self.comm.rank == 0:
                n = next(k for k in itertools.count(1)
                         if not path.with_name(f"{path.stem}_resumed{k}.bp").exists())
            path = path.with_name(f"{path.stem}_resumed{self.comm.bcast(n, root=0)}.bp")
        return path

    def _readable_xdmf(self) -> bool:
        """Whether an earlier run left a complete XDMF/HDF5 pair to append to; a pair a killed
        run left behind (HDF5 superblock missing) is renamed ``*.broken`` and a new series begins."""
        h5 = self.xdmf_path.with_suffix(".h5")
        ok = None
        if self.comm.rank == 0:
            ok = self.xdmf_path.exists() and h5.exists() and _first_bytes(h5, 8) == HDF5_SIGNATURE
            if not ok:
                for path in (self.xdmf_path, h5):
                    if path.exists():
                        path.replace(path.with_name(path.name + ".broken"))
                        warn(log, f"{path} was left incomplete by the stopped run; kept as {path.name}.broken, "
                                  "the displacement series starts again")
        return self.comm.bcast(ok, root=0)

    def _write_xdmf(self, load: float) -> None:
        """Append one time step (the displacement and the contact pressure); the file is opened
        and closed around it, so a run killed between steps leaves a readable series."""
        import dolfinx.io
        with dolfinx.io.XDMFFile(self.comm, str(self.xdmf_path), "a" if self.xdmf_started else "w") as f:
            if not self.xdmf_started:
                f.write_mesh(self.disc.dolfinx_mesh)
            f.write_function(self.u_p1, load)
            f.write_function(self.pressure.function, load)
        self.xdmf_started = True

    def step(self, records: list[dict], wall: float, pressure: ContactPressure, surface=None) -> None:
        """Write the converged step ``records[-1]``: XDMF and VTX (the displacement and ``pressure``'s
        nodal contact pressure, :data:`PRESSURE_FIELD`), checkpoint, a summary marked running
        with the wall time so far (``wall`` [s], kept by a resumed run), load_path.csv, and the
        pictures of the contact pressure (:meth:`_pictures`; ``surface`` the problem's contact
        checks) if the step reaches one of the load factors of ``pressure_at``."""
        load = records[-1]["load"]
        due = [t for t in self.pressure_at if load >= t - LOAD_TOL]
        if due:
            self.pressure_at = self.pressure_at[len(due):]
            u = post.gather_to_root(self.comm, *self.disc.output_point_displacements(self.x),
                                    self.disc.output_mesh.n_points)
            self._pictures(u, pressure, surface, load, final=False)
        self.u_p2 = self.disc.output_function(self.x, self.u_p2)
        self.u_p1.interpolate(self.u_p2)
        self.pressure.set(pressure)
        self._write_xdmf(records[-1]["load"])
        self.vtx.write(records[-1]["load"], self.pressure.function)
        partial = self.summary(records, wall, False, RUNNING)
        keys, values = self._gathered(self.x)
        previous = {} if self.control.previous is None else {"previous": self._gathered(self.control.previous)[1]}
        if self.comm.rank == 0:
            control = {CONTROL_PREFIX + k: v for k, v in self.control.state().items()}
            post.write_npz(self.out / CHECKPOINT, keys=keys, values=values, **previous, **control)
            post.write_json(self.out / "summary.json", partial)
            post.write_load_path_csv(self.out / "load_path.csv", records)

    def _gathered(self, x: PETSc.Vec) -> tuple[np.ndarray, np.ndarray] | tuple[None, None]:
        """The nodal values of ``x`` (k, 2) by sorted node key (k,) on rank 0 (collective)."""
        pieces = self.comm.gather(self.disc.get_state(x), root=0)
        if self.comm.rank != 0:
            return None, None
        keys = np.concatenate([k for k, _ in pieces])
        order = np.argsort(keys)
        return keys[order], np.concatenate([v for _, v in pieces])[order]

    def finish(self, summary: dict, u: np.ndarray | None, pressure: ContactPressure, surface=None) -> None:
        """Write the final summary.json and load_path.csv and the pictures of the last state
        (``u`` the displacements of the output mesh's points on rank 0, ``pressure`` the contact
        pressure, at the nodes of ``surface``, the problem's contact checks) and close the VTX series."""
        self.vtx.close()
        if self.comm.rank == 0:
            post.write_json(self.out / "summary.json", summary)
            post.write_load_path_csv(self.out / "load_path.csv", summary["steps"])
        load = max([s["load"] for s in summary["steps"] if s["converged"]], default=0.0)
        self._pictures(u, pressure, surface, load, final=True)

    def _pictures(self, u: np.ndarray | None, pressure: ContactPressure, surface, load: float, final: bool) -> None:
        """The pictures of a state at load factor ``load`` (drawn on rank 0; ``u`` the displacements of
        the output mesh's points there). At the end of the run (``final``): in 2D ``deformed.png``,
        ``uy.png`` and ``contact_pressure.png`` (:mod:`.post`), in 3D ``final-deformed.png``,
        ``final-clip.png`` and ``final-pressure.png`` (:func:`.pictures3d.write_pictures_3d`, when
        PyVista is installed); at a load of ``pressure_at``: ``contact_pressure_<load>.png`` in 2D,
        ``contact_pressure_<load>-{deformed,clip,pressure}.png`` in 3D."""
        if self.comm.rank != 0:
            return
        name = "contact_pressure" if final else f"contact_pressure_{load:.4g}"
        if self.disc.gdim == 3:
            try:
                from dolfinx_sfvem.output.pictures3d import write_pictures_3d
            except ImportError:
                return
            solids = [tag for tag in np.unique(self.disc.output_mesh.tags).tolist()
                      if not self.disc.materials[tag].is_medium]
            checked = pressure.pressure.size > 0
            write_pictures_3d(self.out, "final" if final else name, self.disc.output_mesh, u, solids,
                              surface=surface if checked else None, pressure=pressure.pressure if checked else None,
                              outlines=self.disc.cell_outlines)
            return
        method = self.disc.method
        if final:
            post.plot_deformed_polygons(self.out / "deformed.png", self.disc.output_mesh, u,
                                        title=f"{method}: load factor {load:.3g}")
            post.plot_deformed_polygons(self.out / "uy.png", self.disc.output_mesh, u, node_values=u[:, 1],
                                        title="u_y")
        post.plot_contact_pressure(self.out / f"{name}.png", pressure,
                                   title=f"{method}: contact pressure at load factor {load:{'.3g' if final else '.4g'}}")
