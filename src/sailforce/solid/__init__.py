"""The arm as a solid: a gmsh mesh solved by CalculiX, to check the frame model and to fit its load cell.

- :mod:`~sailforce.solid.layout`: the arm as plane parts, holes and cell faces;
- :mod:`~sailforce.solid.mesh`: gmsh meshes of a layout;
- :mod:`~sailforce.solid.ccx`: CalculiX decks, runs and results;
- :mod:`~sailforce.solid.cell`: the cell's depth calibrated to its datasheet, its in-situ compliance fitted;
- :mod:`~sailforce.solid.arm`: one pose solved for the two unit loads;
- :mod:`~sailforce.solid.compare`: the solid against the frame at a pose;
- :mod:`~sailforce.solid.sweep`: poses cached on disk and run on Dask; Table 4 from the solid.

Needs the ``solid`` extra (gmsh) and CalculiX's ``ccx`` (Debian ``calculix-ccx``).
"""

from .arm import SOLID_JOINTS, SolidResponse, solve_pose
from .ccx import SolverError, ccx_binary
from .cell import CellDepth, CellFit, calibrate_depth, fit_compliance, with_compliance
from .mesh import MeshError

__all__ = ["SOLID_JOINTS", "CellDepth", "CellFit", "MeshError", "SolidResponse", "SolverError", "calibrate_depth",
           "ccx_binary", "fit_compliance", "solve_pose", "with_compliance"]
