"""opdeform: physics-based deformation with oriented particles.

The C core (``opdeform._core``) does the work; the modules here turn any array-like into the contiguous
float64/int32 buffers the core reads, and the core's arrays back into numpy arrays. See README.md.
This file only re-exports: Graph (graph.py), Simulation (simulation.py), ContactGroup (contact.py), Skin and the mesh constraints
(mesh.py), GoalFit and the goal helpers (goals.py), the materials module (presets, stiffness in Pa, warnings), as_array (_arguments.py), the io and meshes modules, and ShapeMatching where built.
"""

from . import _core, goals, io, materials, meshes
from ._arguments import as_array
from ._core import SolverError
from .contact import ContactGroup
from .goals import GoalFit, goal_frequency, relative_deform
from .graph import Graph
from .mesh import Skin, add_vertex_direction, pin_vertices
from .simulation import Simulation

__all__ = ["ContactGroup", "GoalFit", "Graph", "Simulation", "Skin", "SolverError", "add_vertex_direction", "as_array", "goal_frequency",
           "goals", "io", "materials", "meshes", "pin_vertices", "relative_deform"]
__version__ = _core.__version__

if hasattr(_core, "ShapeMatching"):  # the baseline of issue 5, left out of the Blender packages (-Dbaselines=false)
    from .shape_matching import ShapeMatching  # noqa: F401
