"""Making meshes: the tools, one job per module, and the paper's geometries made with them.

polygon_sets
    :class:`PolygonSet` (polygons not yet validated), CSR helpers, :func:`glue` (concatenation with
    coincident points merged; ``PolygonMesh`` then inserts the hanging nodes).
dual
    Dual polygons of a triangle mesh.
grids
    Structured quadrilateral grids, a quad grid with a refined patch.
gmsh_io
    gmsh session, ``.msh`` input, ``.geo``/``.msh`` output.
gmsh_duals
    gmsh Frontal-Delaunay triangle meshes and their duals (Voronoi-like polygons).
gmsh3d
    3D: the tetrahedra or hexahedra of a gmsh model as a ``CellMesh``; gmsh tetrahedra of a geometry.
hexahedra
    3D without gmsh: tensor-product box grids, quadrilaterals extruded into hexahedra, hexahedra
    split into tetrahedra.
prisms
    Polyhedra: any polygon mesh extruded into prisms (a ``PolyhedronMesh``).
octree
    Polyhedra: octrees of a box refined where asked, 2:1 balanced, coarse cubes with hanging vertices.
octree_tetrahedra
    Polyhedra: an octree block under gmsh tetrahedra, conforming on the block's top plane.
voronoi
    Polyhedra: Voronoi cells clipped to a box.
npz
    The ``.npz`` format of polygon meshes.
diagnostics
    T-junctions and a summary of a mesh.

benchmarks
    The paper's 2D geometries, meshed: C-box, box, punch, multi-object, thick cylinder, arch, PneuNet.
benchmarks3d
    The 3D geometries: C-box, Hertz sphere (tetrahedra or an octree block), thick sphere, PneuNet.

Users reach all of them through the namespace :mod:`dolfinx_sfvem.meshes`.
"""
