"""Meshes for users: the paper's benchmark geometries, the 3D benchmarks and the tools that make meshes.

Every 2D generator returns a :class:`~dolfinx_sfvem.mesh.polygon_mesh.PolygonMesh` whose polygons carry an
integer region tag (:data:`SOLID`, :data:`MEDIUM`, ...); every 3D one a
:class:`~dolfinx_sfvem.mesh.cell_mesh.CellMesh` of tetrahedra or hexahedra with the same tags, or, for the
coming 3D SFVEM, a :class:`~dolfinx_sfvem.mesh.polyhedron_mesh.PolyhedronMesh` (:func:`extrude_polygons`,
:func:`octree_box`, :func:`voronoi_box`, :func:`hertz3d_octree`). This module
only gathers names: the geometries live in :mod:`dolfinx_sfvem.meshing.benchmarks` and
:mod:`dolfinx_sfvem.meshing.benchmarks3d`, the mesh-making tools in :mod:`dolfinx_sfvem.meshing`.
"""
from dolfinx_sfvem.meshing.benchmarks import (
    BASE_LAYER, CBOX_COLUMN, FIRST_CHAMBER, MEDIUM, SOLID, Arc, Benchmark, PneuNet, box, cbox, cbox_grid, multi_object,
    pneumatic_actuator, punch, shallow_arch, thick_cylinder)
from dolfinx_sfvem.meshing.benchmarks3d import (
    SPHERE, Benchmark3D, Plane, PneuNet3D, SphereSurface, cbox3d, hertz3d, hertz3d_octree, pneunet3d, thick_sphere)
from dolfinx_sfvem.meshing.diagnostics import describe, t_junctions
from dolfinx_sfvem.meshing.dual import dual_polygons
from dolfinx_sfvem.meshing.gmsh_duals import polygon_rectangle
from dolfinx_sfvem.meshing.gmsh_io import from_gmsh, gmsh_session, model_cells, region_names, write_gmsh
from dolfinx_sfvem.meshing.gmsh3d import from_gmsh_3d, read_gmsh
from dolfinx_sfvem.meshing.grids import quad_rectangle, quads_with_hanging_nodes
from dolfinx_sfvem.meshing.hexahedra import box_grid, extrude, split_hexahedra
from dolfinx_sfvem.meshing.octree import OctreeMesh, octree_box
from dolfinx_sfvem.meshing.octree_tetrahedra import octree_under_tetrahedra
from dolfinx_sfvem.meshing.prisms import extrude_polygons
from dolfinx_sfvem.meshing.voronoi import voronoi_box
from dolfinx_sfvem.meshing.npz import NPZ_FORMAT, read_polygons, write_polygons
from dolfinx_sfvem.meshing.polygon_sets import PolygonSet, glue
from dolfinx_sfvem.mesh.polyhedron_mesh import PolyhedronMesh

__all__ = ["SOLID", "MEDIUM", "CBOX_COLUMN", "Arc", "Benchmark", "cbox", "cbox_grid", "box", "punch", "multi_object",
           "thick_cylinder", "shallow_arch", "BASE_LAYER", "FIRST_CHAMBER", "PneuNet", "pneumatic_actuator",
           "PolygonSet", "glue", "dual_polygons", "quad_rectangle", "quads_with_hanging_nodes", "polygon_rectangle",
           "read_gmsh", "from_gmsh", "gmsh_session", "model_cells", "region_names", "write_gmsh", "read_polygons",
           "write_polygons", "NPZ_FORMAT", "describe", "t_junctions",
           "SPHERE", "Benchmark3D", "Plane", "SphereSurface", "PneuNet3D", "cbox3d", "hertz3d", "hertz3d_octree",
           "thick_sphere", "pneunet3d", "extrude", "box_grid", "split_hexahedra", "from_gmsh_3d",
           "PolyhedronMesh", "OctreeMesh", "octree_box", "octree_under_tetrahedra", "extrude_polygons",
           "voronoi_box"]
