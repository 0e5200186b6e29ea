"""dolfinx-sfvem: third medium contact with the stabilization-free virtual element method.

Order-2 SFVEM (Xu & Wriggers) on arbitrary polygonal meshes inside DOLFINx 0.5, with a
P2 Lagrange FEM reference on the same UFL energy.
"""
__version__ = "0.1.0"
