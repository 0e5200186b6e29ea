"""The generated pages of the documentation site, written at every build into ``docs/_generated``.

- ``api.rst``: the API reference, one autodoc entry per name of ``dolfinx_sfvem.__all__``, grouped
  by job (a name in no group goes to "Other names", so none can be missing);
- ``gallery/index.rst`` and ``gallery/<demo>.rst``: one page per demo in ``demos/`` from its module
  docstring (reStructuredText, the numpy-docstring style the demos are written in) with its pictures
  from ``docs/figures``; a new ``demos/<name>.py`` gets its page by itself;
- ``gallery/tools.rst``: the modules of ``demos/`` that are tools, not demos.

Nothing here runs a demo. This module does not import Sphinx, so the tests can check the pages
(tests/test_docs.py); docs/conf.py calls :func:`write_pages` when the build starts.
"""
from __future__ import annotations

import ast
import inspect
import pathlib
import re
import shutil
import types
import typing

REPO = pathlib.Path(__file__).resolve().parents[2]
DEMOS = REPO / "demos"
DOCS = REPO / "docs"
FIGURES = DOCS / "figures"
GENERATED = DOCS / "_generated"

#: modules of demos/ that are tools (drivers of studies, shared helpers), not demos; besides these,
#: every module whose name starts with "_" is a helper
TOOLS = ("compare", "local_refinement", "refinement", "restart", "results", "results_plan", "results_report",
         "results_runner")

#: the pictures of each demo's gallery page (file in docs/figures, caption), made by ``make results``;
#: a demo not listed gets every docs/figures/<name with - for _>-*.png
FIGURES_OF: dict[str, list[tuple[str, str]]] = {
    "cbox": [
        ("cbox-mesh1-vem-deformed.png", "u_y = -0.5, medium mesh 1: deformed mesh (SFVEM, left; Q2 FEM: results page)"),
        ("cbox-mesh1-vem-uy.png", "u_y = -0.5, medium mesh 1: u_y"),
        ("cbox-uy1-vem-deformed.png", "u_y = -1 with alpha_r = 20: deformed mesh"),
        ("cbox-curves.png", "Force and tip displacement over the load path, SFVEM and FEM"),
        ("cbox-pressure-after-h0.05.png", "Contact pressure along the beams at full load (h = 0.05)"),
    ],
    "box_self_contact": [
        ("box-mesh1-vem-deformed.png", "Mesh 1, gamma = 1e-5, alpha_r = 1: deformed mesh"),
        ("box-mesh1-vem-uy.png", "Mesh 1: u_y"),
        ("box-mesh1-vem-gap.png", "Gap between the flanges over the load path"),
        ("box-fig4.png", "Paper Fig. 4: gap and force over the load, alpha_r = 0.1, mesh 3, three values of gamma"),
        ("box-curves.png", "Force and gap over the load path, SFVEM and FEM"),
    ],
    "punch": [
        ("punch-soft-vem-deformed.png", "Soft punch, u_y = -1.3: deformed mesh"),
        ("punch-soft-vem-uy.png", "Soft punch: u_y"),
        ("punch-rigid-vem-deformed.png", "Rigid punch: deformed mesh"),
        ("punch-curves.png", "Force over the load path, SFVEM and FEM"),
    ],
    "multi_object": [
        ("multi-bc1-vem-deformed.png", "BC 1 (discs u_x = 0): deformed mesh"),
        ("multi-bc1-vem-zoom.png", "BC 1: the squeezed medium under a disc"),
        ("multi-bc2-vem-deformed.png", "BC 2 (discs free to slide): deformed mesh"),
        ("multi-curves.png", "Force over the load path, SFVEM and FEM"),
    ],
    "hertz": [
        ("hertz-vem-gamma1e-5.png", "gamma = 1e-5: block-top pressure against Hertz's ellipse, and a(P)"),
        ("hertz-vem-gamma1e-6-dual.png", "gamma = 1e-6, thin layer on dual polygons: full load"),
    ],
    "cbox3d": [
        ("cbox3d-point-hex-deformed.png", "Point contact at the full load, Q2 hexahedra (20, 4, 7), rotation "
                                          "regularization, gamma = 1e-5, alpha_r = 10 (the defaults): the upper "
                                          "beam twisted down onto the lower one, which it pushes down"),
        ("cbox3d-point-hex-clip.png", "The same state cut normal to y through the solids' centre: the medium "
                                      "squeezed between the beams (smallest gap 0.040, J down to 0.013)"),
        ("cbox3d-point-hex-pressure.png", "The contact pressure at the full load on the surface where it is largest, "
                                          "seen along the contact normal"),
        ("cbox3d-point-hex-curves.png", "Reaction at the moved corner and smallest gap over the load path "
                                        "(17 steps, 100 Newton iterations, no failed step)"),
    ],
    "hertz3d": [
        ("hertz3d-core0.03-curves.png", "h_core = 0.03 (39,402 unknowns), gamma = 1e-5, the full load (indent 0.04): "
                                        "force against indentation with Hertz's (half-space, and less the settlement "
                                        "at the clamped bottom), block-top pressure against radius with Hertz's "
                                        "(p_max 1.8 % above p0, the fitted radius 4.5 % below Hertz's)"),
        ("hertz3d-core0.03-pressure.png", "The contact pressure at the full load on the sphere's tip, seen from below "
                                          "through the faint block (quarter model: the axis is the zone's corner)"),
        ("hertz3d-core0.03-clip.png", "A cut through the contact at the full load (x = 0 plane): the 0.03 core under "
                                      "the sphere, the squeezed medium between the solids"),
        ("hertz3d-core0.03-deformed.png", "The solids at the full load (medium hidden): the mesh's 0.03 core under "
                                          "the sphere"),
    ],
    "user_mesh3d": [
        ("user_mesh3d-curves.png", "The default run (2,748 curved tetrahedra, 14,043 unknowns): the plate's force on "
                                   "the eighth model and the smallest gap between the solids against the plate's "
                                   "travel; the gaps close through the medium, then the ring is squeezed"),
        ("user_mesh3d-clip.png", "At the full load, cut normal to x: the ring flattened under the plate, the medium "
                                 "squeezed between them (smallest gap 2.3e-3)"),
        ("user_mesh3d-pressure.png", "The contact pressure on the ring's top at the full load, seen from above"),
    ],
    "pneunet3d": [
        ("pneunet3d-curves.png", "2 chambers, Q2 hexahedra, h = 2: tip angle, smallest gap and mean chamber volume "
                                 "change against the chamber pressure (dotted: first contact)"),
        ("pneunet3d-clip.png", "At 10 kPa, cut normal to y through the contact: the sidewalls meet across the gap"),
        ("pneunet3d-deformed.png", "The deformed half actuator at 10 kPa, medium hidden"),
        ("pneunet3d-pressure.png", "The medium's contact pressure on the free chamber's sidewall at 10 kPa"),
    ],
    "snap_through": [
        ("snap-through.png", "Shallow arch, h = 0.01: apex force against apex displacement, SFVEM and FEM under "
                             "arc-length and displacement control, with the beam model's limit loads; shaded: the "
                             "unstable branch (negative pivots)"),
    ],
    "thick_cylinder": [
        ("thick-cylinder-convergence.png", "Relative L2 and H1 errors and the error of u_r at the inner arc against "
                                           "h, small p against Lamé and follower, dead and cavity pressure against "
                                           "the BVP, SFVEM and FEM: O(h^2)"),
    ],
    "pneumatic_actuator": [
        ("pneumatic-actuator-deformed.png", "The actuators at 5 kPa, h = 1: SFVEM (left) and FEM (right)"),
        ("pneumatic-actuator-curves.png", "Tip angle, smallest gap and mean chamber area against the chamber "
                                          "pressure; dotted: each method's first contact"),
    ],
    "thick_sphere": [
        ("thick-sphere-convergence.png", "Relative errors of u_r(a) and of the recorded conjugate (the cavity's volume "
                                         "change) against the unknowns, four cases: O(h^2), set by the flat faces"),
        ("thick-sphere-vem-convergence.png", "The same with the SFVEM on the tetrahedra read as polyhedra: the same "
                                             "errors and order on each mesh, with 2.7-2.9 times the unknowns"),
    ],
}

#: the API reference's groups: (heading, what it holds, names of dolfinx_sfvem.__all__)
API_GROUPS = (
    ("Problem and load path", "Define a problem, solve it, control the path.",
     ("ContactProblem", "LoadStepping", "ArcLength", "SolveFailed", "Adaptivity", "Compression", "NearContact")),
    ("Meshes", "Polygon meshes, meshes of tetrahedra or hexahedra (3D), the paper's geometries, the 3D "
     "benchmarks and the mesh-making tools (``sf.meshes``).",
     ("PolygonMesh", "CellMesh", "meshes")),
    ("Materials", "Region energies written once in UFL (paper Eqs. 2-17).",
     ("Energy", "Hyperelastic", "ThirdMedium", "UserEnergy")),
    ("Discretizations", "The SFVEM and the FEM reference behind ``ContactProblem``, for scripts of one's own.",
     ("Discretization", "VEMSpace", "SFVEMDiscretization", "LagrangeDiscretization", "linear_elastic_stiffness")),
)
#: modules outside ``__all__`` that users import by name, documented after it
API_EXTRA_MODULES = (("dolfinx_sfvem.exact", "Exact answers for validating loads (``from dolfinx_sfvem import exact``)."),)


class Demo(typing.NamedTuple):
    name: str                           # module name, e.g. "cbox"
    title: str                          # the docstring's first line
    body: str                           # the rest of the docstring
    figures: list[tuple[str, str]]      # (file in docs/figures, caption)


# --------------------------------------------------------------------------- demos
def demo_names(demos: pathlib.Path = DEMOS) -> tuple[list[str], list[str]]:
    """The modules of ``demos`` split into (demos, tools), sorted by name."""
    names = sorted(path.stem for path in demos.glob("*.py"))
    tools = [name for name in names if name in TOOLS or name.startswith("_")]
    return [name for name in names if name not in tools], tools


def module_docstring(path: pathlib.Path) -> str:
    """The module docstring of ``path``; ValueError naming the file if it has none."""
    doc = ast.get_docstring(ast.parse(path.read_text()))
    if not doc:
        raise ValueError(f"{path.relative_to(REPO)} has no module docstring: the gallery page is made from it")
    return doc


def figures_of(name: str, figures: pathlib.Path = FIGURES) -> list[tuple[str, str]]:
    """The pictures of demo ``name``: :data:`FIGURES_OF`, else ``<name>.png`` and every ``<name>-*.png``
    (``_`` as ``-``) with its file name as caption. ValueError naming a listed picture that does not exist."""
    if name not in FIGURES_OF:
        stem = name.replace("_", "-")
        paths = sorted(figures.glob(stem + ".png")) + sorted(figures.glob(stem + "-*.png"))
        return [(path.name, path.stem) for path in paths]
    missing = [file for file, _ in FIGURES_OF[name] if not (figures / file).is_file()]
    if missing:
        raise ValueError(f"gallery page of demos/{name}.py: no {', '.join(missing)} in docs/figures "
                         f"(made by make results; see FIGURES_OF in {pathlib.Path(__file__).relative_to(REPO)})")
    return FIGURES_OF[name]


def read_demo(name: str, demos: pathlib.Path = DEMOS) -> Demo:
    """The gallery entry of ``demos/<name>.py``."""
    title, _, body = module_docstring(demos / f"{name}.py").partition("\n")
    return Demo(name, title.strip(), body.strip("\n"), figures_of(name))


_LITERAL = re.compile(r"(``.+?``)")
_UNDERLINE = re.compile(r"^([=\-~^\"'`#*+])\1{2,}\s*$")


def escape_rst(text: str) -> str:
    """``text`` (a docstring in reStructuredText) with ``*`` and ``|`` escaped outside ``literals``
    and literal blocks, where plain-text maths uses them (``E*``, ``|F|``); section underlines are
    lengthened to their escaped titles."""
    out: list[str] = []
    literal_block = False
    for line in text.splitlines():
        if literal_block and line.strip() and not line[0].isspace():
            literal_block = False
        if literal_block or _UNDERLINE.match(line):
            if _UNDERLINE.match(line) and out and len(out[-1].rstrip()) > len(line.rstrip()):
                line = line[0] * len(out[-1].rstrip())
            out.append(line)
        else:
            out.append("".join(part if part.startswith("``") else re.sub(r"([*|])", r"\\\1", part)
                               for part in _LITERAL.split(line)))
            literal_block = line.rstrip().endswith("::")
    return "\n".join(out)


def heading(text: str, char: str, overline: bool = False) -> list[str]:
    """A reStructuredText section title."""
    rule = char * len(text)
    return ([rule] if overline else []) + [text, rule, ""]


def demo_page(demo: Demo) -> str:
    """The gallery page of one demo."""
    lines = [f".. _demo-{demo.name}:", "", *heading(escape_rst(demo.title), "=", overline=True),
             f"``demos/{demo.name}.py``; its options: ``python3 demos/{demo.name}.py --help``. "
             "The text below is the demo's docstring.", "", escape_rst(demo.body), ""]
    if demo.figures:
        lines += heading("Pictures", "-")
        lines += ["From the runs of ``make results`` (:doc:`/results`).", ""]
        for file, caption in demo.figures:
            lines += [f".. figure:: /figures/{file}", "   :width: 90%", "", f"   {escape_rst(caption)}", ""]
    return "\n".join(lines)


def gallery_index(demos: list[Demo]) -> str:
    """The gallery's start page: one entry per demo with its first picture, and the tools."""
    lines = [*heading("Demo gallery", "=", overline=True),
             "One script per example in ``demos/``, runnable serially or under ``mpirun``; every page is the "
             "demo's own docstring (problem, geometry, parameters, outputs, commands) with the pictures of its "
             "runs. Shared options of every demo: ``--method vem|fem``, ``--steps``, ``--out``, ``--h``, "
             "``--gamma``, ``--alpha-r``, ``--resume DIR``, PETSc options (``-tmc_snes_monitor``); see "
             ":doc:`/guide/quickstart`.", ""]
    lines += [".. list-table::", "   :widths: 40 60", ""]
    for demo in demos:
        picture = (f".. image:: /figures/{demo.figures[0][0]}\n          :target: {demo.name}.html"
                   if demo.figures else "(no pictures yet)")
        lines += [f"   * - {picture}", f"     - :ref:`demo-{demo.name}`", "", f"       ``demos/{demo.name}.py``", ""]
    lines += ["The scripts in ``demos/`` that are not demos: :doc:`tools`.", "",
              ".. toctree::", "   :hidden:", "", *[f"   {demo.name}" for demo in demos], "   tools", ""]
    return "\n".join(lines)


def tools_page(tools: list[str], demos: pathlib.Path = DEMOS) -> str:
    """The list of the tools in demos/ with the first line of each docstring."""
    lines = [*heading("Tools in demos/", "=", overline=True),
             "Scripts and modules of ``demos/`` that drive studies or are shared by the demos; they are not "
             "demos themselves and have no gallery page.", ""]
    for name in tools:
        doc = " ".join(module_docstring(demos / f"{name}.py").split("\n\n")[0].split())
        lines += [f"``demos/{name}.py``", f"   {escape_rst(doc)}", ""]
    return "\n".join(lines)


# --------------------------------------------------------------------------- API reference
def directive(name: str, obj: object) -> str:
    """The autodoc directive that documents ``dolfinx_sfvem.<name>``."""
    if isinstance(obj, types.ModuleType):
        return f".. automodule:: {obj.__name__}\n   :members:\n   :undoc-members:\n"
    if inspect.isclass(obj) and issubclass(obj, BaseException):
        return f".. autoexception:: dolfinx_sfvem.{name}\n"
    if inspect.isclass(obj):
        return f".. autoclass:: dolfinx_sfvem.{name}\n   :members:\n   :show-inheritance:\n"
    if callable(obj):
        return f".. autofunction:: dolfinx_sfvem.{name}\n"
    return f".. autodata:: dolfinx_sfvem.{name}\n"


def api_groups(public: typing.Sequence[str]) -> list[tuple[str, str, list[str]]]:
    """:data:`API_GROUPS` restricted to ``public``, plus "Other names" for the public names in no group."""
    grouped = {name for _, _, names in API_GROUPS for name in names}
    groups = [(title, text, [name for name in names if name in public]) for title, text, names in API_GROUPS]
    groups.append(("Other names", "Public names not yet sorted into a group above.",
                   [name for name in public if name not in grouped]))
    return [group for group in groups if group[2]]


def api_page(package: types.ModuleType) -> str:
    """The API reference of ``package`` (``dolfinx_sfvem``): every name of its ``__all__``."""
    lines = [*heading("API reference", "=", overline=True),
             "Every public name of ``dolfinx_sfvem`` (its ``__all__``), from the docstrings, generated at each "
             "build. Import as ``import dolfinx_sfvem as sf``; the user guide (:doc:`/guide/index`) shows them "
             "at work.", ""]
    for title, text, names in api_groups(list(package.__all__)):
        lines += heading(title, "-") + [text, ""]
        for name in names:
            lines += heading(name, "~") + [directive(name, getattr(package, name))]
    lines += heading("Other modules", "-")
    for module, text in API_EXTRA_MODULES:
        lines += heading(module, "~") + [text, "", f".. automodule:: {module}\n   :members:\n"]
    return "\n".join(lines)


def documented_names(page: str) -> set[str]:
    """The names of ``dolfinx_sfvem`` that ``page`` documents with an autodoc directive."""
    names = set(re.findall(r"^\.\. auto(?:class|exception|function|data):: dolfinx_sfvem\.(\w+)$", page, flags=re.M))
    return names | set(re.findall(r"^\.\. automodule:: dolfinx_sfvem\.(\w+)$", page, flags=re.M))


# --------------------------------------------------------------------------- all pages
def pages(package: types.ModuleType) -> dict[str, str]:
    """Every generated page: path relative to ``docs/_generated`` -> reStructuredText."""
    demo_list, tools = demo_names()
    demos = [read_demo(name) for name in demo_list]
    api = api_page(package)
    missing = set(package.__all__) - documented_names(api)
    if missing:
        raise ValueError(f"the API reference misses {sorted(missing)} of dolfinx_sfvem.__all__")
    return {"api.rst": api, "gallery/index.rst": gallery_index(demos), "gallery/tools.rst": tools_page(tools),
            **{f"gallery/{demo.name}.rst": demo_page(demo) for demo in demos}}


def write_pages(package: types.ModuleType, out: pathlib.Path = GENERATED) -> list[pathlib.Path]:
    """Write :func:`pages` into ``out`` (emptied first, so that a removed demo loses its page)."""
    generated = pages(package)
    shutil.rmtree(out, ignore_errors=True)
    written = []
    for relative, text in generated.items():
        path = out / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
        written.append(path)
    return written
