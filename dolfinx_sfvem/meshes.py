"""Polygonal meshes for users: the paper's benchmark geometries and the tools that make meshes.

Every generator returns a :class:`~dolfinx_sfvem.polygon_mesh.PolygonMesh` whose polygons carry an
integer region tag (:data:`SOLID`, :data:`MEDIUM`, ...). This module only gathers names: the
geometries live in :mod:`dolfinx_sfvem.benchmarks`, the mesh-making tools in
:mod:`dolfinx_sfvem.meshing`.
"""
from .benchmarks import (BASE_LAYER, CBOX_COLUMN, FIRST_CHAMBER, MEDIUM, SOLID, Arc, Benchmark, PneuNet, box, cbox,
                         cbox_grid, multi_object, pneumatic_actuator, punch, shallow_arch, thick_cylinder)
from .meshing.diagnostics import describe, t_junctions
from .meshing.dual import dual_polygons
from .meshing.gmsh_duals import polygon_rectangle
from .meshing.gmsh_io import from_gmsh, gmsh_session, model_cells, region_names, write_gmsh
from .meshing.grids import quad_rectangle, quads_with_hanging_nodes
from .meshing.npz import NPZ_FORMAT, read_polygons, write_polygons
from .meshing.polygon_sets import PolygonSet, glue

__all__ = ["SOLID", "MEDIUM", "CBOX_COLUMN", "Arc", "Benchmark", "cbox", "cbox_grid", "box", "punch", "multi_object",
           "thick_cylinder", "shallow_arch", "BASE_LAYER", "FIRST_CHAMBER", "PneuNet", "pneumatic_actuator",
           "PolygonSet", "glue", "dual_polygons", "quad_rectangle", "quads_with_hanging_nodes", "polygon_rectangle",
           "from_gmsh", "gmsh_session", "model_cells", "region_names", "write_gmsh", "read_polygons",
           "write_polygons", "NPZ_FORMAT", "describe", "t_junctions"]
