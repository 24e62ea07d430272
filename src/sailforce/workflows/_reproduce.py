"""``reproduce``: the seed paper's virtual study, what its model could have been, and its solid check, as ``sail reproduce`` runs them.

Nothing is written here: the report layer writes the tables, figures and
report of a :class:`Reproduction` (``sail reproduce`` does both).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ToolError
from ..paper.seed import seed_table4
from ..paper.seed_model import SeedModelResult, seed_model_study
from ..paper.study import StudyResult, run_study, table4_from_rows
from ..robot import Robot
from ..sensing.polynomial import DEFAULT_CRITERION, DEFAULT_THRESHOLD

#: The solid's element size [m] for the study's 16 poses.
DEFAULT_SOLID_MESH_SIZE = 4e-3


@dataclass(frozen=True)
class SolidStudy:
    """The study's sweeps solved as solids: the sweep result, Table 4 from solid, frame and seed, the frame's torques."""

    result: object  #: :class:`sailforce.solid.sweep.SweepResult`
    tables: dict[str, np.ndarray]  #: ``solid``, ``frame``, ``seed``: Table 4 ``(n, 5)`` each
    frame_torques: np.ndarray  #: ``(n_poses, 2, 2)``
    mesh_size: float  #: [m]
    seconds: float


@dataclass(frozen=True)
class Reproduction:
    """What :func:`reproduce` computed."""

    studies: tuple[StudyResult, ...]  #: the robot's own joints first, then the comparison pass
    study_seconds: float  #: the studies' wall time
    seed_model: SeedModelResult | None = None
    solid: SolidStudy | None = None
    notes: tuple[str, ...] = ()  #: what the fit cache did that people should know (a damaged entry, a folder not written)


def reproduce(robot: Robot, *, transduction: str = "deflection", compare_joints: str | None = "pin",
              criterion: str = DEFAULT_CRITERION, threshold: float = DEFAULT_THRESHOLD, seed_model: bool = True,
              seed_robot: Robot | None = None, solid: bool = False, solid_mesh_size: float = DEFAULT_SOLID_MESH_SIZE,
              progress: Callable[[str], None] | None = None, workers: int = 1,
              with_studies: Callable[[tuple[StudyResult, ...]], None] | None = None,
              fit_cache_dir: Path | None = None) -> Reproduction:  # fmt: skip
    """Run the seed's study on ``robot`` (and on its ``compare_joints`` twin), fit the seed-model families, solve the solid.

    ``seed_robot`` is the robot the seed-model families start from (default
    ``robot``); ``progress(step)`` hears each step as it starts (``"study, pin
    joints"``, ``"solid model"``) and each seed-model family as its fit ends
    (``"seed model: <family> fitted"``).  The families' fits run here, or on a pool of
    ``workers`` processes (:func:`~sailforce.paper.seed_model.fit_families`; ``sail reproduce``: one per core).
    ``with_studies(studies)``, if given, is called once the studies are done, while
    the families are fitted (``sail reproduce`` writes the studies' tables and
    figures then).  With ``workers`` > 1 the solid's poses are solved on a thread of their own while the
    families are fitted.  ``fit_cache_dir`` caches the families' fits (``sail reproduce``:
    :func:`~sailforce.io.cache.default_cache_dir` ``("fits")`` unless ``--no-cache``).
    """
    say = progress or (lambda step: None)
    robots = [robot] + ([robot.with_joints(compare_joints)] if compare_joints not in (None, "none", robot.joints.label) else [])
    studies, seconds = [], 0.0
    for each in robots:
        say(f"study, {each.joints.label} joints")
        started = time.perf_counter()
        studies.append(run_study(each, transduction, criterion=criterion, threshold=threshold))
        seconds += time.perf_counter() - started
    fits = None
    done = tuple(studies)
    notes: list[str] = []
    with ThreadPoolExecutor(1) as background:
        solid_future = None
        if solid:
            from ..solid.arm import check_joints

            check_joints(robot)  # refused before anything runs
            if workers > 1 and seed_model:  # the solid's CalculiX solves run while the families are fitted
                say(f"solid model, {robot.joints.label} joints ({solid_mesh_size * 1e3:g} mm), with the seed model")
                solid_future = background.submit(solid_pass, robot, studies[0], solid_mesh_size)
        try:
            if seed_model:
                fits = seed_model_study(seed_robot or robot, studies[0].protocol,
                                        progress=lambda name: say(f"seed model: {name} fitted"), workers=workers,
                                        while_fitting=None if with_studies is None else lambda: with_studies(done),
                                        cache_dir=fit_cache_dir, notes=notes)  # fmt: skip
            elif with_studies is not None:
                with_studies(done)
            solid_study = None
            if solid_future is not None:
                solid_study = solid_future.result()
            elif solid:
                say(f"solid model, {robot.joints.label} joints ({solid_mesh_size * 1e3:g} mm)")
                solid_study = solid_pass(robot, studies[0], solid_mesh_size)
        except BaseException:
            background.shutdown(wait=False, cancel_futures=True)
            raise
    return Reproduction(done, seconds, fits, solid_study, tuple(notes))


def solid_pass(robot: Robot, study: StudyResult, mesh_size: float = DEFAULT_SOLID_MESH_SIZE) -> SolidStudy:
    """The study protocol's sweeps as solids (cached): their Table 4 beside the frame's and the seed's."""
    from ..fem.response import simulate
    from ..solid.arm import check_joints
    from ..solid.sweep import SolidSettings, default_cache_dir, response_rows, run_poses, seed_poses

    check_joints(robot)
    poses, sweeps = seed_poses(study.protocol)
    started = time.perf_counter()
    result = run_poses(robot, poses, SolidSettings(mesh_size=mesh_size), cache_dir=default_cache_dir())
    seconds = time.perf_counter() - started
    rows = [response_rows(result, s) for s in sweeps]
    if rows[0] is None or rows[1] is None:
        raise ToolError(f"the solid failed at {len(result.failures)} poses: {next(iter(result.failures.values()))}")
    tables = {"solid": table4_from_rows(robot.arm, study.protocol, rows[0], rows[1]), "frame": study.table4,
              "seed": seed_table4()}  # fmt: skip
    pose_array = np.array(poses)
    frame_torques = simulate(robot, pose_array[:, 0], pose_array[:, 1]).torques
    return SolidStudy(result, tables, frame_torques, mesh_size, seconds)
