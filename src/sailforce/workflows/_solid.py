"""``check_solid``: the arm solved as a gmsh + CalculiX solid at one pose and compared with the frame, as ``sail solid`` does.

The load cell's depth is first calibrated to its datasheet deflection (cached),
then two unit loads at the handle give every force angle by superposition
(:mod:`sailforce.solid.compare`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..paper.study import Protocol
from ..robot import Robot
from ..solid.arm import SolidResponse, check_joints, solve_pose
from ..solid.cache import SolidCache
from ..solid.cell import CellDepth
from ..solid.compare import READINGS, compare, curves, frame_readings, pose_deg
from ..solid.sweep import SolidSettings, cell_depth, default_cache_dir
from ..sweep import check_not_singular

#: Default element size [m]: 2 mm solves a 2-D pose in about 10 s on one core.
DEFAULT_MESH_SIZE = 2e-3


@dataclass(frozen=True)
class SolidCheck:
    """The solid at one pose against the frame: its response, the cell's depth, and the readings under ``force_N``."""

    robot: Robot
    theta1: float  #: [rad]
    theta2: float  #: [rad]
    force_N: float
    mesh_size: float  #: [m]
    response: SolidResponse
    depth: CellDepth
    seconds: float  #: the solve's wall time, the depth's calibration included
    phi: np.ndarray  #: the force angles of the curves [rad]
    solid_curves: dict[str, np.ndarray]  #: per reading of :data:`~sailforce.solid.compare.READINGS`, ``(2, n_phi)``
    frame_curves: dict[str, np.ndarray]
    comparison: dict  #: :func:`sailforce.solid.compare.compare`
    notes: tuple[str, ...] = field(default=())  #: what the cache had to say (a damaged entry, a read-only folder)


def check_solid(robot: Robot, theta1: float, theta2: float, *, mesh_size: float = DEFAULT_MESH_SIZE,
                force_N: float = Protocol().force_N, cache_dir: Path | None = None, workdir: Path | None = None,
                status: Callable[[str], None] | None = None) -> SolidCheck:  # fmt: skip
    """Solve ``robot`` as a solid at (theta1, theta2) [rad] and compare it with its frame model.

    ``cache_dir`` (default :func:`sailforce.solid.sweep.default_cache_dir`)
    keeps the cell's calibrated depth; ``workdir`` keeps CalculiX's deck and
    output; ``status(text)`` hears what is being done.
    """
    check_joints(robot)
    check_not_singular(theta1, theta2)
    say = status or (lambda text: None)
    started = time.perf_counter()
    cache = SolidCache(cache_dir or default_cache_dir())
    say("calibrating the load cell's depth")
    depth = cell_depth(robot, SolidSettings(mesh_size=mesh_size), cache)
    say(f"solving the solid at {pose_deg(theta1, theta2)} ({mesh_size * 1e3:g} mm mesh)")
    response = solve_pose(robot, theta1, theta2, cell_depth=depth.depth, mesh_size=mesh_size, stresses=True, workdir=workdir)
    seconds = time.perf_counter() - started
    phi = np.radians(Protocol().phi_deg)
    frame = frame_readings(robot, theta1, theta2)
    return SolidCheck(
        robot, theta1, theta2, force_N, mesh_size, response, depth, seconds, phi,
        {name: curves(getattr(response, name), phi, force_N) for name in READINGS},
        {name: curves(frame[name], phi, force_N) for name in READINGS},
        compare(robot, response), tuple(cache.notes),
    )  # fmt: skip
