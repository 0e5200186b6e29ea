"""dolfinx-sfvem: third medium contact with the stabilization-free virtual element method.

Order-2 SFVEM (Xu & Wriggers) on arbitrary polygonal meshes inside DOLFINx (0.5.2 and 0.11), with the
energy written once in UFL.

Main entry points
-----------------
PolygonMesh
    Polygonal mesh with region tags (validation, hanging nodes, sub-triangulation).
CellMesh
    Mesh of one DOLFINx cell type with region tags: tetrahedra or hexahedra for 3D problems.
Hyperelastic, ThirdMedium, UserEnergy
    Region energies (paper Eqs. 2-17).
Adaptivity, Compression, NearContact
    Adaptive refinement of the medium during a load path (``solve(..., adapt=...)``).
ContactProblem
    Mesh + energies + boundary conditions + loads, and its state; ``solve`` runs a load path.
LoadStepping, ArcLength
    The controls of a load path: prescribed load factor (default), arc-length.
Discretization
    The contract both discretizations fulfil (residual, tangent, constraints, state, output).
VEMSpace, SFVEMDiscretization
    The discrete space and the residual/tangent assembly, for use in own scripts.
LagrangeDiscretization
    The P2/Q2 Lagrange FEM reference on the same energies (``ContactProblem(..., method="fem")``).
linear_elastic_stiffness
    The plane-strain linear-elastic SFVEM stiffness of one polygon.
meshes
    The paper's geometries (benchmarks.py) and the mesh-making tools (meshing/) in one namespace.
"""
from . import _compat  # noqa: F401  (first: with the dolfinx-solver wheels it loads MPI before the bindings)
from . import meshes
from .adaptivity import Adaptivity, Compression, NearContact
from .arclength import ArcLength
from .cell_mesh import CellMesh
from .elasticity import linear_elastic_stiffness
from .energy import Energy, Hyperelastic, ThirdMedium, UserEnergy
from .discretization import Discretization
from .fem import LagrangeDiscretization
from .polygon_mesh import PolygonMesh
from .problem import ContactProblem
from .snes import SolveFailed
from .stepping import LoadStepping
from .space import VEMSpace
from .vem import SFVEMDiscretization

__version__ = "0.1.0"

__all__ = ["PolygonMesh", "CellMesh", "Energy", "Hyperelastic", "ThirdMedium", "UserEnergy", "ContactProblem",
           "Discretization", "VEMSpace", "SFVEMDiscretization", "LagrangeDiscretization", "linear_elastic_stiffness",
           "meshes", "SolveFailed", "Adaptivity", "Compression", "NearContact", "LoadStepping",
           "ArcLength"]
