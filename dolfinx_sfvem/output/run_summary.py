"""summary.json of a run, typed: what :meth:`ContactProblem.solve` writes, read back.

The file is written by :class:`~dolfinx_sfvem.path_following.load_path.LoadPath` (``summary``): the
discretization (``method``, ``dofs`` and the mesh facts of its ``describe()``), the run
(``ranks``, ``wall_time_s``, ``converged``, ``message``), where its Newton iterations went
(``newton``, :func:`newton_economy`), the ``parameters`` and one record per attempted load step
(:class:`StepRecord`). Every reader of the file uses
:func:`read_summary` instead of the raw keys.
"""
from __future__ import annotations

import dataclasses
import json
import math
import os
import pathlib
import typing

#: ``message`` of a run between its steps (what a killed run leaves behind)
RUNNING = "running"
#: ``message`` of a run stopped by SIGINT/SIGTERM (followed by the signal number)
STOPPED_BY_SIGNAL = "stopped by signal"
#: summary entries of the run itself; every other top-level entry is a fact of the discretization
_RUN_KEYS = ("method", "dofs", "ranks", "wall_time_s", "converged", "stable", "message", "newton", "parameters",
             "steps")


#: an observer of a load path: ``f(problem)`` returns one number, or several named ones
Observer = typing.Callable[[typing.Any], typing.Union[float, typing.Mapping[str, float]]]


@dataclasses.dataclass
class Result:
    """Outcome of a load path (:meth:`~dolfinx_sfvem.ContactProblem.solve`).

    Attributes
    ----------
    converged : bool
        The load factor ``until`` (default 1, the full load) was reached, or the arc-length's
        stop criterion met (and no solids overlap).
    load : float
        Load factor of the last converged step.
    steps : list of dict
        The converged steps, in order (``summary.json``'s records: ``load``, ``reaction``
        ``{name: [R_x, R_y]}``, ``loads`` ``{name: {magnitude, displacement}}``, ``gap``,
        ``extra`` (observers), ...).
    attempts : list of dict
        Every attempted step, failed ones included (``converged`` False, with ``failure``).
    wall_time_s : float
    summary : dict
        The content of summary.json.
    message : str
        Why the run stopped ("" if it converged).
    stable : bool or None
        Whether the last converged state is a stable equilibrium (:mod:`~dolfinx_sfvem.path_following.stability`):
        False when its tangent has negative pivots on a path under load or displacement control,
        None when not known (no LDLᵀ factorization, or arc-length control).
    """
    converged: bool
    load: float
    steps: list[dict]
    attempts: list[dict]
    wall_time_s: float
    summary: dict
    message: str = ""
    stable: bool | None = None


@dataclasses.dataclass
class StepRecord:
    """One attempted step as the load path writes it (an entry of ``steps``; read back as
    :class:`Step`)."""
    step: int
    load: float
    newton_iterations: int
    residual_norms: list[float]
    converged: bool
    reaction: dict[str, list[float]] = dataclasses.field(default_factory=dict)
    min_J: float = float("nan")
    kinked_elements: int = 0
    negative_pivots: int | None = None
    stable: bool | None = None
    failure: str = ""
    gap: dict | None = None
    contact: list[dict] = dataclasses.field(default_factory=list)
    max_displacement: float = float("nan")
    wall_time_s: float = 0.0
    extra: dict[str, typing.Any] = dataclasses.field(default_factory=dict)
    dofs: int = 0                   # unknowns of the mesh the step was solved on
    refined_polygons: int = 0       # polygons split after this step by adaptive refinement
    loads: dict[str, dict[str, float]] = dataclasses.field(default_factory=dict)   # magnitude, displacement per load
    rejected_trial_states: int = 0  # trial states of Newton's line searches outside the energy's domain


def newton_economy(records: typing.Sequence[typing.Mapping[str, typing.Any]]) -> dict[str, float]:
    """Where the Newton iterations of the attempts ``records`` (summary.json's ``steps``) went:
    ``iterations`` in all, ``in_failed_attempts`` of them in attempts that were not accepted,
    ``failed_share`` = in_failed_attempts / iterations (0 without iterations) and
    ``rejected_trial_states`` (trial states outside the energy's domain, all attempts)."""
    total = sum(int(r["newton_iterations"]) for r in records)
    failed = sum(int(r["newton_iterations"]) for r in records if not r["converged"])
    return {"iterations": total, "in_failed_attempts": failed, "failed_share": failed / total if total else 0.0,
            "rejected_trial_states": sum(int(r.get("rejected_trial_states", 0)) for r in records)}


def describe_economy(economy: typing.Mapping[str, float]) -> str:
    """One line of :func:`newton_economy`'s numbers."""
    return (f"{economy['iterations']} Newton iterations, {economy['in_failed_attempts']} "
            f"({economy['failed_share']:.0%}) in failed attempts, {economy['rejected_trial_states']} trial "
            "states rejected")


@dataclasses.dataclass(frozen=True)
class Step:
    """One attempted load step (an entry of ``steps``; fields of
    :class:`StepRecord`, missing ones at their defaults).

    Attributes
    ----------
    load : float
        Load factor lambda in [0, 1].
    converged : bool
    step : int
        Number of converged steps up to this one.
    newton_iterations : int
    residual_norms : list of float
        |R| before each Newton iteration and after the last.
    reaction : dict name -> [R_x, R_y]
        Reaction of every prescribed boundary condition (force per unit thickness).
    min_J : float or None
        Smallest det F over the quadrature points (None: not recorded, in files of older versions).
    kinked_elements : int
    negative_pivots : int or None
        Negative eigenvalues of the tangent at the last state Newton factorized (MUMPS LDL^T
        inertia; None without it, and in files of older versions).
    stable : bool or None
        False: a converged state with negative pivots under load or displacement control, an
        unstable equilibrium (:mod:`~dolfinx_sfvem.path_following.stability`); None: not known (no LDLᵀ,
        arc-length control, a failed attempt, files of older versions).
    failure : str
        Why a failed step failed ("" if converged).
    gap : dict or None
        The smallest signed gap between the solids (:mod:`~dolfinx_sfvem.physics.contact`: ``value``,
        ``x``, ``X``, ``region``, ...); None without two solids.
    contact : list of dict
        Contact quantities per pair of bodies facing each other.
    max_displacement : float or None
        Largest |u| over the nodes (None: not recorded, in files of older versions).
    wall_time_s : float
        Wall time of the step [s].
    extra : dict name -> value
        The observers' values.
    dofs : int
        Unknowns of the mesh the step was solved on (0: not recorded, in files of older versions).
    refined_polygons : int
        Polygons split by adaptive refinement after this step (0: none).
    loads : dict name -> {"magnitude": float, "displacement": float}
        Every load's magnitude at this step and its work-conjugate displacement
        (:mod:`~dolfinx_sfvem.physics.loads`).
    rejected_trial_states : int
        Trial states of Newton's line searches outside the energy's domain (J <= 0, a fold, NaN).
    """

    load: float
    converged: bool
    step: int = 0
    newton_iterations: int = 0
    residual_norms: list[float] = dataclasses.field(default_factory=list)
    reaction: dict[str, list[float]] = dataclasses.field(default_factory=dict)
    min_J: float | None = None
    kinked_elements: int = 0
    negative_pivots: int | None = None
    stable: bool | None = None
    failure: str = ""
    gap: dict | None = None
    contact: list[dict] = dataclasses.field(default_factory=list)
    max_displacement: float | None = None
    wall_time_s: float = 0.0
    extra: dict[str, typing.Any] = dataclasses.field(default_factory=dict)
    dofs: int = 0
    refined_polygons: int = 0
    loads: dict[str, dict[str, float]] = dataclasses.field(default_factory=dict)
    rejected_trial_states: int = 0

    def value(self, key: str) -> float | None:
        """An observer of ``extra``, else a numeric field of the step (e.g. ``max_displacement``);
        None if neither is a number."""
        value = self.extra.get(key, getattr(self, key, None))
        return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else None

    def force(self, condition: str) -> float | None:
        """-R_y of the boundary condition ``condition`` (None if it has no reaction here)."""
        reaction = self.reaction.get(condition)
        return -float(reaction[1]) if reaction is not None else None


@dataclasses.dataclass(frozen=True)
class RunSummary:
    """The content of summary.json.

    Attributes
    ----------
    method : str
        ``"vem"`` or ``"fem"``.
    dofs : int
        Global number of unknowns.
    ranks : int
        MPI ranks of the run.
    wall_time_s : float
        Solve wall time [s] (NaN possible for a run that was killed).
    converged : bool
        The full load was reached.
    message : str
        Why the run stopped ("" if converged; :data:`RUNNING` or :data:`STOPPED_BY_SIGNAL` ...
        for a run that can be resumed).
    parameters : dict
        The problem's parameters (materials, boundary conditions, the demo's options).
    steps : tuple of Step
        Every attempted step, failed ones included.
    discretization : dict
        Mesh facts of the method: ``polygons`` and ``projection_order_histogram`` (SFVEM),
        ``cells``, ``cell_type``, ``quadrature_degree``, ... (FEM).
    """

    method: str
    dofs: int
    ranks: int
    wall_time_s: float
    converged: bool
    message: str
    parameters: dict[str, typing.Any]
    steps: tuple[Step, ...]
    discretization: dict[str, typing.Any]

    @classmethod
    def from_dict(cls, data: typing.Mapping[str, typing.Any]) -> RunSummary:
        """From the JSON content (missing run entries at neutral values: an old file still reads)."""
        fields = {f.name for f in dataclasses.fields(Step)}
        return cls(method=str(data.get("method", "")), dofs=int(data.get("dofs", 0)), ranks=int(data.get("ranks", 1)),
                   wall_time_s=float(data["wall_time_s"]) if data.get("wall_time_s") is not None else math.nan,
                   converged=bool(data.get("converged", False)), message=str(data.get("message", "")),
                   parameters=dict(data.get("parameters", {})),
                   steps=tuple(Step(**{k: v for k, v in s.items() if k in fields}) for s in data.get("steps", [])),
                   discretization={k: v for k, v in data.items() if k not in _RUN_KEYS})

    @property
    def converged_steps(self) -> list[Step]:
        """The converged steps, in order."""
        return [s for s in self.steps if s.converged]

    @property
    def final_step(self) -> Step | None:
        """The last converged step (None if there is none)."""
        steps = self.converged_steps
        return steps[-1] if steps else None

    @property
    def stable(self) -> bool | None:
        """Whether the last converged state is a stable equilibrium (:attr:`Step.stable`; None
        if not known or no step converged)."""
        final = self.final_step
        return final.stable if final is not None else None

    @property
    def load_reached(self) -> float:
        """Largest load factor of a converged step (0 if none)."""
        return max([s.load for s in self.converged_steps], default=0.0)

    @property
    def newton_iterations(self) -> int:
        """Newton iterations of all attempts, failed ones included."""
        return sum(s.newton_iterations for s in self.steps)

    @property
    def interrupted(self) -> bool:
        """Killed between steps or stopped by a signal, i.e. ``solve(..., resume=True)`` continues it."""
        return self.message == RUNNING or self.message.startswith(STOPPED_BY_SIGNAL)


def read_summary(path: str | os.PathLike) -> RunSummary | None:
    """The summary.json at ``path`` (the file or its directory); None if absent or unreadable."""
    path = pathlib.Path(path)
    if path.is_dir():
        path = path / "summary.json"
    try:
        return RunSummary.from_dict(json.loads(path.read_text()))
    except (OSError, ValueError, TypeError):
        return None
