"""What a mesh is: polygons and polyhedra, meshes of them and of DOLFINx cells, and their refinement."""
