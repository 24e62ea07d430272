"""Solid poses in bulk: one task per pose, cached on disk, run here or on a Dask cluster.

A pose's task meshes, solves and parses (:func:`solve_task`); it carries the
robot as its robot-file tables, so it pickles small and any worker with
sailforce and ccx can run it.  Results are cached (:mod:`sailforce.solid.cache`)
under the SHA-256 of everything that decides them (:func:`task_inputs`): the
robot's tables, the pose, the mesh size, the cell's calibrated depth and
:data:`MODEL_VERSION`; each entry holds those inputs and a checksum, and is
checked on every read.  A rerun solves only the poses whose entry is new or
damaged; the client writes the cache (workers need not share its disk), each
file atomically, so a killed sweep leaves no half-written entry.

Failures: :func:`sailforce.distributed.run_tasks` retries a task that raised
or whose worker died; a pose that still fails comes back with its error in
:attr:`SweepResult.failures`, never dropped.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

import numpy as np

from ..distributed import DEFAULT_RETRIES, run_tasks
from ..errors import InputError
from ..io.cache import default_cache_dir as _default_cache_dir
from ..io.robotfile import robot_data, robot_from_data
from ..robot import Robot
from .arm import SolidResponse, check_joints, solve_pose
from .cache import SolidCache, cache_key
from .cell import CellDepth, calibrate_depth

#: Bump when a change to the solid model changes its results: every cached pose is then solved again.
#: 2: entries hold their inputs and a checksum (sailforce.solid.cache).
MODEL_VERSION = 2


def default_cache_dir() -> Path:
    """``$SAIL_CACHE_DIR``, else ``$XDG_CACHE_HOME/sailforce/solid`` (``~/.cache/sailforce/solid``)."""
    return _default_cache_dir("solid")


@dataclass(frozen=True)
class SolidSettings:
    """How the solid is built: the element size [m] of its plane-stress mesh."""

    mesh_size: float = 0.002

    def as_dict(self) -> dict:
        return {"mesh_size": self.mesh_size}


@dataclass(frozen=True)
class PoseTask:
    """One pose to solve: the robot's tables, the pose [rad], the settings, the cell depth [m]."""

    robot: dict
    theta1: float
    theta2: float
    settings: SolidSettings
    cell_depth: float

    @property
    def key(self) -> str:
        return task_key(self)


def task_inputs(task: PoseTask) -> dict:
    """Everything that decides a pose's result (module docstring), as JSON."""
    return {"kind": "pose", "version": MODEL_VERSION, "robot": task.robot, "pose": [repr(task.theta1), repr(task.theta2)],
            "settings": task.settings.as_dict(), "cell_depth": repr(task.cell_depth)}  # fmt: skip


def task_key(task: PoseTask) -> str:
    """SHA-256 of :func:`task_inputs`: the name of the pose's cache entry."""
    return cache_key(task_inputs(task))


def checked_response(value: dict, task: PoseTask) -> SolidResponse:
    """A cached or solved pose's result, refused (``ValueError``) unless it is the task's pose, in shape and finite."""
    response = SolidResponse.from_dict(value)
    if (response.theta1, response.theta2) != (task.theta1, task.theta2):
        raise InputError(f"it holds the pose ({response.theta1!r}, {response.theta2!r}), not the one asked for")
    for name, shape in (("torques", (2, 2)), ("deflection", (2, 2)), ("relative", (2, 2)), ("moment_balance", (2,))):
        array = getattr(response, name)
        if array.shape != shape or array.dtype.kind != "f" or not np.all(np.isfinite(array)):
            raise InputError(f"{name} is not a finite {shape} array")
    if response.dofs <= 0:
        raise InputError(f"dofs = {response.dofs}")
    return response


def solve_task(task: PoseTask) -> dict:
    """Solve one pose (runs on a worker): the :class:`SolidResponse` as a dict."""
    robot = robot_from_data(task.robot)
    response = solve_pose(robot, task.theta1, task.theta2, cell_depth=task.cell_depth,
                          mesh_size=task.settings.mesh_size)  # fmt: skip
    return response.as_dict()


def cell_depth(robot: Robot, settings: SolidSettings, cache: SolidCache | Path | None) -> CellDepth:
    """The calibrated cell depth (:func:`sailforce.solid.cell.calibrate_depth`), cached like the poses."""
    cache = cache if isinstance(cache, SolidCache) else SolidCache(cache)
    data = robot_data(robot)
    inputs = {"kind": "cell", "version": MODEL_VERSION, "cell": [data["loadcells"], data["materials"]["loadcells"]],
              "settings": settings.as_dict()}  # fmt: skip
    cached = cache.read(inputs, _checked_depth)
    if isinstance(cached, CellDepth):
        return cached
    depth = calibrate_depth(robot.loadcell, settings.mesh_size)
    cache.write(inputs, depth.__dict__)
    return depth


def _checked_depth(value: dict) -> CellDepth:
    depth = CellDepth(**value)
    lengths = (depth.depth, depth.achieved, depth.target)
    if not all(isinstance(x, float) and math.isfinite(x) and x > 0 for x in lengths) or type(depth.solves) is not int:
        raise InputError(f"the cell's depth, deflections and solves must be positive numbers, not {value}")
    return depth


@dataclass(frozen=True)
class SweepResult:
    """Every pose's response (None where it failed), which came from the cache, and the failures' errors."""

    poses: tuple[tuple[float, float], ...]
    responses: tuple[SolidResponse | None, ...]
    cached: int
    failures: dict[int, str] = field(default_factory=dict)  #: pose index -> error
    depth: CellDepth | None = None
    notes: tuple[str, ...] = ()  #: what the cache did that people should know: damaged entries, a cache not written

    @property
    def complete(self) -> bool:
        return not self.failures


def run_poses(robot: Robot, poses, settings: SolidSettings = SolidSettings(), *, cache_dir: Path | None = None,
              workers: int | None = None, scheduler: str | None = None, retries: int = DEFAULT_RETRIES,
              advance: Callable[[float], None] | None = None, solver: Callable[[PoseTask], dict] = solve_task) -> SweepResult:  # fmt: skip
    """Solve ``robot`` at every (theta1, theta2) [rad] of ``poses``; cached ones are read, the rest run as tasks."""
    check_joints(robot)
    advance = advance or (lambda amount: None)
    poses = tuple((float(a), float(b)) for a, b in poses)
    cache = SolidCache(cache_dir)
    depth = cell_depth(robot, settings, cache)
    data = robot_data(robot)
    tasks = [PoseTask(data, a, b, settings, depth.depth) for a, b in poses]
    responses: list[SolidResponse | None] = [None] * len(tasks)
    todo = []
    for k, task in enumerate(tasks):
        entry = cache.read(task_inputs(task), partial(checked_response, task=task))
        if isinstance(entry, SolidResponse):
            responses[k] = entry
            advance(1)
        else:
            todo.append(k)
    failures = {}
    outcomes = run_tasks(solver, [tasks[k] for k in todo], workers=workers, scheduler=scheduler, retries=retries,
                         advance=advance) if todo else []  # fmt: skip
    for k, outcome in zip(todo, outcomes):
        try:
            if not outcome.ok:
                raise InputError(outcome.error)
            responses[k] = checked_response(outcome.value, tasks[k])
            cache.write(task_inputs(tasks[k]), outcome.value)
        except (ValueError, KeyError, TypeError) as exc:
            failures[k] = str(exc)
    return SweepResult(poses, tuple(responses), len(tasks) - len(todo), failures, depth, tuple(cache.notes))


def seed_poses(protocol) -> tuple[list[tuple[float, float]], tuple[slice, slice]]:
    """The protocol's two sweeps as one pose list [rad], and the slice of each sweep in it."""
    poses = []
    for cell in (1, 2):
        theta1, theta2 = protocol.sweep_poses(cell)
        poses += list(zip(theta1.tolist(), theta2.tolist()))
    n1 = protocol.sweep_poses(1)[0].size
    return poses, (slice(0, n1), slice(n1, len(poses)))


def read_poses(path: Path) -> list[tuple[float, float]]:
    """Poses [rad] from a CSV file with columns ``theta1_deg, theta2_deg`` (a header row, then one pose per row)."""
    from ..io.files import read_numeric_csv

    names, table = read_numeric_csv(path, min_columns=2)
    try:
        i, j = names.index("theta1_deg"), names.index("theta2_deg")
    except ValueError:
        raise InputError(f"{path}: expected columns theta1_deg and theta2_deg, found {', '.join(names)}") from None
    return [(math.radians(a), math.radians(b)) for a, b in table[:, [i, j]].tolist()]


def response_rows(result: SweepResult, indices: slice, reading: str = "deflection") -> np.ndarray | None:
    """``(n, 2, 2)`` of ``reading`` over the poses ``indices``, or None if any of them failed."""
    chosen = result.responses[indices]
    if any(r is None for r in chosen):
        return None
    return np.stack([getattr(r, reading) for r in chosen if r is not None])
