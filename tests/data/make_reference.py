"""Write the stored test data of this directory. Run it on Debian 12's stack (DOLFINx 0.5.2,
PETSc 3.18, gmsh 4.8), serially::

    .venv/bin/python tests/data/make_reference.py            # cbox-reference.json
    .venv/bin/python tests/data/make_reference.py --meshes   # the meshes as well, then the reference

- ``cbox-h0.1.npz``: the C-box polygon mesh at h_solid = 0.1 (``meshes.cbox``);
  ``cbox-reference.json``: its load path (``tests/test_reference.py``) with the stack's versions;
- ``square-h<h>.npz``, ``square-h<h>-fem.npz`` for h = 0.2, 0.1, 0.05: the Voronoi-like polygon
  mesh of the unit square (``meshes.polygon_rectangle``) and its triangulation with matched P2
  unknowns (``remesh.matched_triangulation``), as ``tests/test_agreement.py`` uses them.

All meshes come from gmsh, whose output differs between versions (PyPI has no gmsh older than
4.9), so the tests read them from here instead of meshing. ``--meshes`` makes them with the
installed gmsh; only do that on Debian 12 (gmsh 4.8), where the results of the tests were
measured.
"""
from __future__ import annotations

import argparse
import json
import pathlib
import sys

import gmsh

import dolfinx_sfvem as sf  # before petsc4py: it loads the MPI of the dolfinx-solver wheels first
from dolfinx_sfvem import _compat, meshes
from dolfinx_sfvem.mesh.remesh import matched_triangulation
from petsc4py import PETSc

DATA = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(DATA.parent))
import test_agreement  # noqa: E402
import test_reference  # noqa: E402


def write_meshes() -> None:
    """The C-box and unit-square meshes (module docstring) with the installed gmsh."""
    meshes.write_polygons(test_reference.MESH, meshes.cbox(h_solid=0.1).mesh)
    for h in test_agreement.SQUARE_SIZES:
        mesh = meshes.polygon_rectangle(1.0, 1.0, h, tag=1)
        _, tri = matched_triangulation(mesh)
        polygon, fem = test_agreement.square_mesh_paths(h)
        meshes.write_polygons(polygon, mesh)
        meshes.write_polygons(fem, sf.PolygonMesh(tri.points, tri.triangles, tri.tags))


def write_reference() -> None:
    """``cbox-reference.json``: the C-box load path on the stored mesh and the stack it ran on."""
    stack = {"dolfinx": _compat.DOLFINX_VERSION, "petsc": ".".join(map(str, PETSc.Sys.getVersion())),
             "gmsh": gmsh.__version__, "python": sys.version.split()[0]}
    reference = {"stack": stack, **test_reference.cbox_load_path()}
    test_reference.REFERENCE.write_text(json.dumps(reference, indent=1) + "\n")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--meshes", action="store_true", help="make the meshes with the installed gmsh first")
    if p.parse_args().meshes:
        write_meshes()
    write_reference()


if __name__ == "__main__":
    main()
