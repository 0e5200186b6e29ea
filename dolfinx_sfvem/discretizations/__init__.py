"""The discretizations of a region-wise energy: the order-2 SFVEM on polygons and polyhedra, the degree-2 Lagrange FEM,
and the contract they share."""
