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
    The paper's geometries and the mesh-making tools (both in meshing/) in one namespace.
"""
from dolfinx_sfvem import _compat  # noqa: F401  (first: with the dolfinx-solver wheels it loads MPI before the bindings)
from dolfinx_sfvem import meshes
from dolfinx_sfvem.path_following.adaptivity import Adaptivity, Compression, NearContact
from dolfinx_sfvem.path_following.arclength import ArcLength
from dolfinx_sfvem.mesh.cell_mesh import CellMesh
from dolfinx_sfvem.discretizations.elasticity import linear_elastic_stiffness
from dolfinx_sfvem.physics.energy import Energy, Hyperelastic, ThirdMedium, UserEnergy
from dolfinx_sfvem.discretizations.discretization import Discretization
from dolfinx_sfvem.discretizations.fem import LagrangeDiscretization
from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh
from dolfinx_sfvem.problem import ContactProblem
from dolfinx_sfvem.path_following.snes import SolveFailed
from dolfinx_sfvem.path_following.stepping import LoadStepping
from dolfinx_sfvem.discretizations.space import VEMSpace
from dolfinx_sfvem.discretizations.vem import SFVEMDiscretization

__version__ = "0.1.0"

__all__ = ["PolygonMesh", "CellMesh", "Energy", "Hyperelastic", "ThirdMedium", "UserEnergy", "ContactProblem",
           "Discretization", "VEMSpace", "SFVEMDiscretization", "LagrangeDiscretization", "linear_elastic_stiffness",
           "meshes", "SolveFailed", "Adaptivity", "Compression", "NearContact", "LoadStepping",
           "ArcLength"]
