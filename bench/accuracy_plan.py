"""The plan of the equal-accuracy benchmark (``accuracy.py``): the four paper examples, what is
compared on each (force, gap), the regions that local refinement splits, and the mesh ladders
with their estimated times. Needs numpy only (no solver).

Every run is a demo of ``demos/`` with its defaults (load stepping and solver included), only
``--method`` and ``--h`` set; a locally refined SFVEM run splits regions of the demo's mesh
before the load path (:class:`Region`, one level at a time, ``ContactProblem.refine``).
"""
from __future__ import annotations

import dataclasses
import typing

import numpy as np

#: region tags of the demos' meshes (dolfinx_sfvem.meshes): solid, medium, second solid (punch, discs)
SOLID, MEDIUM, SECOND_SOLID = 1, 2, 3
METHODS = ("vem", "fem")
METHOD_NAMES = {"vem": "SFVEM", "fem": "FEM"}

Marker = typing.Callable[[np.ndarray], np.ndarray]


@dataclasses.dataclass(frozen=True)
class Region:
    """Polygons split by a local refinement: those of the region tags ``tags`` whose reference
    centroid ``marker`` selects (all of them for None)."""

    marker: Marker | None
    tags: tuple[int, ...]
    description: str


@dataclasses.dataclass(frozen=True)
class Example:
    """One paper example and how it is measured.

    Attributes
    ----------
    key, title, demo
        Short name, page title, demo module (``demos/<demo>.py``).
    options
        Demo options of every run besides ``--method`` and ``--h``.
    force
        Boundary condition whose final -R_y is the force.
    gap
        Observer (``extra``) holding the gap, or ``""`` for the smallest gap between the solids
        (the step's ``gap`` record).
    gap_label
        What the gap is, for the page.
    fem
        What ``--method fem`` discretizes with, for the page.
    regions
        Regions of the local refinements by name.
    """

    key: str
    title: str
    demo: str
    options: tuple[str, ...]
    force: str
    gap: str
    gap_label: str
    fem: str
    regions: dict[str, Region]


@dataclasses.dataclass(frozen=True)
class Config:
    """One run: an example, a method, a uniform mesh size, and the local refinement on top of it.

    Attributes
    ----------
    refine
        (region, levels) pairs applied in order, each one level at a time; empty for a uniform mesh.
    seconds
        Estimated wall time at 1 rank on the shared 2-core machine (start-up included).
    options
        Demo options replacing or added to the example's (``--quick``).
    """

    example: Example
    method: str
    h: float
    seconds: float
    refine: tuple[tuple[str, int], ...] = ()
    options: tuple[str, ...] = ()

    @property
    def kind(self) -> str:
        """``uniform`` or ``local``."""
        return "local" if self.refine else "uniform"

    @property
    def name(self) -> str:
        """e.g. ``cbox-vem-h0.05-solids1-contact2``."""
        return f"{self.example.key}-{self.method}-h{self.h:g}" + "".join(f"-{r}{k}" for r, k in self.refine)

    @property
    def label(self) -> str:
        """e.g. ``h = 0.05, solids 1 level, contact region 2 levels``."""
        if not self.refine:
            return f"uniform h = {self.h:g}"
        return f"h = {self.h:g}, " + ", ".join(f"{self.example.regions[r].description} {k} level{'s' * (k > 1)}"
                                               for r, k in self.refine)

    @property
    def argv(self) -> tuple[str, ...]:
        """The demo's options (without ``--out``)."""
        pairs = dict(zip(self.example.options[::2], self.example.options[1::2]))
        pairs.update(zip(self.options[::2], self.options[1::2]))
        return ("--method", self.method, "--h", f"{self.h:g}", *(x for pair in pairs.items() for x in pair))


def _near_discs(x: np.ndarray, half_width: float) -> np.ndarray:
    """Whether the points x (2, n) lie within ``half_width`` in x of a disc axis x = 1, ..., 7."""
    nearest = np.clip(np.rint(x[0]), 1.0, 7.0)
    return np.abs(x[0] - nearest) < half_width


_SOLIDS = (SOLID, SECOND_SOLID)
EXAMPLES = {
    "cbox": Example(
        "cbox", "C-box (§5.2)", "cbox", ("--uy", "-0.5"), "load", "", "smallest gap between the solids",
        "Q2 on the medium's grid continued through the solid (`cbox_grid`, the demo's default)",
        {"solids": Region(None, (SOLID,), "solids"),
         "contact": Region(lambda x: x[0] > 0.5, (MEDIUM,), "contact region (medium x > 0.5)")}),
    "box": Example(
        "box", "Box self-contact (§5.1)", "box_self_contact", ("--mesh", "1"), "load", "gap",
        "gap between the flanges at mid-span", "P2 on a triangulation with about the SFVEM's unknowns",
        {"contact": Region(lambda x: np.abs(x[0] - 1.0) < 0.45, (MEDIUM,), "contact region (medium |x - 1| < 0.45)")}),
    "punch": Example(
        "punch", "Soft punch (§5.3)", "punch", ("--punch", "soft"), "load", "gap", "gap on the axis",
        "P2 on a triangulation with about the SFVEM's unknowns",
        {"contact": Region(lambda x: x[0] < 0.8, (MEDIUM,), "medium under the punch (x < 0.8)"),
         "near": Region(lambda x: (x[0] < 0.8) & (x[1] > 0.6) & (x[1] < 2.6), _SOLIDS,
                        "solids near the contact (x < 0.8, 0.6 < y < 2.6)")}),
    "multi": Example(
        "multi", "Multiple objects, BC 1 (§5.4)", "multi_object", ("--bc", "1"), "discs", "",
        "smallest gap between the solids", "P2 on a triangulation with about the SFVEM's unknowns",
        {"contact": Region(lambda x: _near_discs(x, 0.3) & (x[1] < 0.35), (MEDIUM,),
                           "medium under the discs (|x - x_i| < 0.3, y < 0.35)"),
         "near": Region(lambda x: _near_discs(x, 0.3) & (x[1] > 0.1) & (x[1] < 0.4), _SOLIDS,
                        "solids near the contacts (|x - x_i| < 0.3, 0.1 < y < 0.4)")}),
}

#: per example: uniform ladders (h, estimated s) of each method and the local refinements
#: (h, refine, estimated s) of the SFVEM; estimates at 1 rank on the loaded shared machine
LADDERS: dict[str, dict[str, typing.Any]] = {
    "cbox": {"vem": ((0.1, 15), (0.05, 25), (0.025, 60), (0.0125, 240), (0.00625, 1500)),
             "fem": ((0.1, 10), (0.05, 15), (0.025, 40), (0.0125, 120), (0.00625, 600)),
             "local": ((0.05, (("solids", 1), ("contact", 2)), 90), (0.05, (("solids", 1), ("contact", 3)), 200),
                       (0.025, (("solids", 1), ("contact", 2)), 300))},
    "box": {"vem": ((0.05, 40), (0.025, 150), (0.0125, 700)),
            "fem": ((0.05, 30), (0.025, 100), (0.0125, 450)),
            "local": ((0.05, (("contact", 2),), 150), (0.025, (("contact", 2),), 400))},
    "punch": {"vem": ((0.2, 40), (0.1, 150), (0.05, 700), (0.025, 4000)),
              "fem": ((0.2, 30), (0.1, 80), (0.05, 350), (0.025, 2000)),
              "local": ((0.1, (("contact", 1), ("near", 1)), 400), (0.05, (("contact", 1), ("near", 1)), 1800))},
    "multi": {"vem": ((0.08, 60), (0.04, 250), (0.02, 1500)),
              "fem": ((0.08, 40), (0.04, 120), (0.02, 700)),
              "local": ((0.04, (("contact", 1), ("near", 1)), 500),)},
}
#: ``--quick``: coarse ladders, loads that stop before or just at contact (a pipeline check)
QUICK: dict[str, dict[str, typing.Any]] = {
    "cbox": {"options": ("--uy", "-0.3"), "vem": ((0.1, 10), (0.05, 15), (0.025, 40)),
             "fem": ((0.1, 8), (0.05, 10), (0.025, 20)), "local": ((0.1, (("contact", 1),), 15),)},
    "box": {"options": ("--uy", "-0.2"), "vem": ((0.1, 10), (0.05, 20)), "fem": ((0.1, 10), (0.05, 15)),
            "local": ((0.1, (("contact", 1),), 15),)},
    "punch": {"options": ("--uy", "-0.5"), "vem": ((0.25, 15), (0.2, 20)), "fem": ((0.25, 12), (0.2, 15)),
              "local": ((0.25, (("contact", 1),), 20),)},
    "multi": {"options": ("--uy", "-0.05"), "vem": ((0.1, 20), (0.08, 25)), "fem": ((0.1, 15), (0.08, 20)),
              "local": ((0.1, (("contact", 1),), 25),)},
}


def plan(quick: bool, examples: typing.Iterable[str] = tuple(EXAMPLES)) -> list[Config]:
    """The runs of the selected examples, cheapest first (a study cut short has every example's
    coarse levels)."""
    runs = []
    for key in examples:
        ladder, example = (QUICK if quick else LADDERS)[key], EXAMPLES[key]
        options = ladder.get("options", ())
        runs += [Config(example, m, h, s, options=options) for m in METHODS for h, s in ladder[m]]
        runs += [Config(example, "vem", h, s, refine, options) for h, refine, s in ladder["local"]]
    return sorted(runs, key=lambda c: c.seconds)
