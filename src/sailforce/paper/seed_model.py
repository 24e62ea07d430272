"""What was the seed's SolidWorks model?  Structure families fitted to its Table 4, and three checks.

The seed publishes a Table 4 (each cell's amplitude and phase against delta)
but not the model that produced it: Table 1 (the geometry) is garbled, and the
joints, the cell's modelling and what was read as the "signal" are not stated.
This module fits :data:`FAMILIES` of frame models to that table with
:func:`~sailforce.paper.table4_fit.identify_table4` and computes the evidence the
reproduce report needs (docs/errata.md, "What was the seed's model?"):

- :func:`phase_drivers`: with bonded joints, geometry (l2, l3, the cell's
  position) sets the size of the phases, not the cell-to-link stiffness ratio;
- :func:`pin_crosstalk`: pin joints are exact only without crosstalk; an axial
  crosstalk c scales cell 1 by 1/(1 - c cot delta) (its axial force is
  N1 = -V1 cot delta) and gives cell 2 a phase offset;
- :func:`implied_lengths`: the torque amplitudes, hence l3 and l2, that the
  seed's pre-compensation RMSEs and pre-scales imply;
- :func:`phase_pattern`: the convention-free facts of a Table 4's phases.
"""

from __future__ import annotations

import dataclasses
import math
import multiprocessing
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator, Mapping
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from contextlib import contextmanager
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from types import SimpleNamespace

import numpy as np
from threadpoolctl import threadpool_limits

from ..errors import CacheEntryError, InputError
from ..fit.identify import AMPLITUDE_WEIGHT, Identification, Problem, best_start, conclude, polish, prepare, solve_start
from ..io.cache import DiskCache, canonical_json, code_fingerprint
from ..io.robotfile import robot_data
from ..io.robotkeys import get_key, with_keys
from ..robot import Robot
from .seed import SEED_PRESCALE, SEED_REGRESSORS, SEED_RMSE, seed_table4
from .study import Protocol, table4
from .table4_fit import Table4Target

#: The seed's Table 4 targets: phase RMS [deg] and normalised-amplitude RMS, per cell.
TARGET_PHASE_RMS_DEG = 1.0
TARGET_SHAPE_RMS = 0.05

_SPRINGS = ("joints.P1.stiffness", "joints.P2.stiffness", "joints.P3.stiffness")
_CROSSTALK = ("loadcells.crosstalk_axial", "loadcells.crosstalk_moment")


@dataclass(frozen=True)
class Family:
    """A model structure: fixed robot-file keys, the free ones, the reading, and whether the shape is fitted."""

    name: str
    description: str
    free: tuple[str, ...]
    transduction: str = "deflection"
    fixed: Mapping[str, object] | None = None
    amplitude_weight: float = AMPLITUDE_WEIGHT  #: 0: phases only

    def robot(self, robot: Robot) -> Robot:
        return with_keys(robot, dict(self.fixed)) if self.fixed else robot


#: The families the report fits, from the seed's likely SolidWorks default (bonded contact) to the closest found.
#: Each runs 17 starts (the robot's values and a 16-point Latin hypercube sample within identify's default bounds).
FAMILIES = (
    Family("bonded", "bonded joints, datasheet cell, far-face deflection; l2, l3 and the cell position free",
           ("links.l2", "links.l3", "loadcells.position"), fixed={"joints.model": "bonded"}),
    Family("spring, phases", "one spring stiffness at all three joints and l3 free; phases only",
           ("joints.stiffness", "links.l3"), fixed={"joints.model": "spring"}, amplitude_weight=0.0),
    Family("springs, deflection", "a spring per joint, l3 and the cell position free; far-face deflection",
           (*_SPRINGS, "links.l3", "loadcells.position")),
    Family("springs, shear", "the same structure read by the bridge (shear at the gauges)",
           (*_SPRINGS, "links.l3", "loadcells.position"), transduction="bridge"),
    Family("springs, shear, crosstalk", "a spring per joint, l2, l3, the cell position, axial and moment "
           "crosstalk free; bridge reading", (*_SPRINGS, "links.l2", "links.l3", "loadcells.position", *_CROSSTALK),
           transduction="bridge"),
    Family("bonded block, shear, crosstalk", "SolidWorks' defaults: bonded joints, the cell a solid 7075 block; "
           "l2, l3, the cell position, axial and moment crosstalk free; bridge reading",
           ("links.l2", "links.l3", "loadcells.position", *_CROSSTALK), transduction="bridge",
           fixed={"joints.model": "bonded", "loadcells.compliance": "block"}),
)  # fmt: skip


@dataclass(frozen=True)
class FamilyFit:
    family: Family
    fit: Identification
    table: np.ndarray  #: (n, 5) the fitted model's Table 4, :data:`~sailforce.paper.study.TABLE4_COLUMNS`
    seconds: float  #: the fit's tasks, summed (when cached: the time the fit took when it was made)
    cached: bool = False  #: read from the fit cache (:func:`fit_families`)

    @property
    def meets_targets(self) -> bool:
        shape_ok = self.family.amplitude_weight > 0 and max(self.fit.shape_rms) <= TARGET_SHAPE_RMS
        return max(self.fit.phase_rms_deg) <= TARGET_PHASE_RMS_DEG and shape_ok

    @property
    def score(self) -> float:
        """How far from the targets: the worst of phase RMS / 1 deg and shape RMS / 5 % (phases-only fits: inf)."""
        if self.family.amplitude_weight == 0:
            return math.inf
        return max(max(self.fit.phase_rms_deg) / TARGET_PHASE_RMS_DEG, max(self.fit.shape_rms) / TARGET_SHAPE_RMS)


def fit_families(
    robot: Robot,
    seed_table: np.ndarray,
    families: tuple[Family, ...] = FAMILIES,
    *,
    protocol: Protocol = Protocol(),
    progress: Callable[[str], None] | None = None,
    workers: int = 1,
    while_fitting: Callable[[], None] | None = None,
    cache_dir: Path | None = None,
    notes: list[str] | None = None,
) -> tuple[FamilyFit, ...]:
    """Fit each family to ``seed_table`` starting from ``robot``; ``progress(name)`` as each family's fit is done.

    Every start of every family, then each family's polish, is a task: ``workers=1`` runs them
    here, more run them on a pool of that many spawned processes (``sail reproduce``: one per
    core).  A script that asks for a pool must guard its entry point with ``if __name__ ==
    "__main__":``, as Python's multiprocessing requires of spawned processes.  The tasks are
    the ones :func:`~sailforce.fit.identify.identify` runs in turn, so the fits are the same
    however many workers there are.  ``FamilyFit.seconds`` is the time its tasks took, summed.
    ``while_fitting()``, if given, runs here once the tasks are in the pool (``sail reproduce``
    draws its figures meanwhile).

    With ``cache_dir``, each family's solution (the polished parameters, residuals and
    Jacobian) is read from there when an entry answers exactly this fit, by this code
    (:data:`FIT_FORMAT`, :func:`_fit_inputs`), and written there after fitting; what the cache
    did that people should know (a damaged entry, a folder that cannot be written) is appended
    to ``notes``.
    """
    problems = [prepare(family.robot(robot), Table4Target(np.asarray(seed_table, dtype=float), family.transduction,
                                                          family.amplitude_weight, protocol), family.free)
                for family in families]  # fmt: skip
    meshes = [problem.starts() for problem in problems]
    cache = DiskCache(cache_dir, entry_format=FIT_FORMAT)
    inputs = [_fit_inputs(family, problem, mesh) for family, problem, mesh in zip(families, problems, meshes)]
    found = [cache.read(entry, partial(_checked_solution, problem=problem)) for entry, problem in zip(inputs, problems)]
    todo = [k for k, hit in enumerate(found) if hit is None]
    tasks = sum(len(meshes[k]) for k in todo)
    if int(workers) < 1:
        raise InputError(f"workers = {workers}: expected at least 1")
    with _pool(min(int(workers), tasks) if tasks else 1) as pool:
        solved = _in_background(lambda stop: _schedule(pool, int(workers), problems, meshes, todo, stop), while_fitting)
        out = []
        for k, (family, problem, mesh) in enumerate(zip(families, problems, meshes)):
            if k in solved:
                best, seconds = solved[k]
                cache.write(inputs[k], _solution_value(best, seconds))
            else:
                best, seconds = found[k]  # type: ignore[misc]  # a hit is _checked_solution's pair
            fit = conclude(problem, best, len(mesh))
            table = table4(fit.robot, family.transduction, protocol=protocol)
            out.append(FamilyFit(family, fit, table, seconds, cached=k not in solved))
            if progress is not None:
                progress(family.name)
    if notes is not None:
        notes.extend(cache.notes)
    return tuple(out)


#: The ``format`` of the fit cache's entries; bump :data:`FIT_VERSION` when what an entry holds changes.
FIT_FORMAT = "sailforce-fit-cache"
FIT_VERSION = 1
#: A cached solution is taken only if its residuals, evaluated afresh, are these within this (relative to their norm).
CACHED_RESIDUAL_RTOL = 1e-9


def _fit_inputs(family: Family, problem: Problem, mesh: np.ndarray) -> dict:
    """Everything that decides a family's fit, as JSON: the code itself, the robot, the target, the starts, the solver."""
    target = problem.target
    assert isinstance(target, Table4Target)
    return canonical_json({
        "kind": "seed-model family", "version": FIT_VERSION, "code": code_fingerprint(),
        "family": {"name": family.name, "free": list(family.free), "transduction": family.transduction,
                   "fixed": {k: v for k, v in dict(family.fixed or {}).items()}, "amplitude_weight": family.amplitude_weight},
        "robot": robot_data(problem.robot), "target": target.table.tolist(), "protocol": dataclasses.asdict(target.protocol),
        "bounds": [[p.low, p.high, p.log] for p in problem.params], "starts": mesh.tolist(),
    })  # fmt: skip


def _solution_value(best, seconds: float) -> dict:
    return {"x": best.x.tolist(), "fun": best.fun.tolist(), "jac": np.asarray(best.jac).tolist(),
            "success": bool(best.success), "seconds": float(seconds)}  # fmt: skip


def _checked_solution(value: dict, problem: Problem) -> tuple[SimpleNamespace, float]:
    """A cached solution as the solver's result and its seconds; :class:`~sailforce.errors.CacheEntryError` unless it is this problem's."""
    n = len(problem.params)
    x, fun, jac = (np.asarray(value[name], dtype=float) for name in ("x", "fun", "jac"))
    low, high = problem.x_bounds
    if x.shape != (n,) or not np.all(np.isfinite(x)) or np.any(x < low) or np.any(x > high):
        raise CacheEntryError(f"its parameters are not {n} finite values within the bounds")
    if fun.ndim != 1 or jac.shape != (fun.size, n) or not (np.all(np.isfinite(fun)) and np.all(np.isfinite(jac))):
        raise CacheEntryError("its residuals or Jacobian have the wrong shape or are not finite")
    fresh = problem.residuals(x)
    if fresh.shape != fun.shape or float(np.linalg.norm(fresh - fun)) > CACHED_RESIDUAL_RTOL * max(float(np.linalg.norm(fresh)), 1.0):
        raise CacheEntryError("its residuals are not those of its parameters")
    seconds = float(value["seconds"])
    if not (math.isfinite(seconds) and seconds >= 0):
        raise CacheEntryError("its fit time is not a time")
    return SimpleNamespace(x=x, fun=fun, jac=jac, success=bool(value["success"])), seconds


def _schedule(pool, workers: int, problems: list[Problem], meshes: list[np.ndarray], todo: list[int],
              stop: threading.Event) -> dict[int, tuple[object, float]]:
    """Each family's starts, then its polish, through ``pool``: ``{family: (polished result, seconds)}``.

    A few tasks more than ``workers`` are in flight at a time, so that a family's polish, put
    first in line when its last start is done, waits for no queue of other starts: the families
    with the most work start first, and the last polish does not run alone at the end.  The best
    start is chosen in start order (:func:`best_start`), whatever order the starts finish in.
    """
    order = sorted(todo, key=lambda k: -len(problems[k].params) * len(meshes[k]))
    waiting: deque[tuple[Callable, int, int]] = deque((solve_start, k, i) for k in order for i in range(len(meshes[k])))
    starts: dict[int, list] = {k: [None] * len(meshes[k]) for k in todo}
    left = {k: len(meshes[k]) for k in todo}
    start_seconds = dict.fromkeys(todo, 0.0)
    running: dict[Future, tuple[Callable, int, int]] = {}
    out: dict[int, tuple[object, float]] = {}
    best_x: dict[int, np.ndarray] = {}
    while (waiting or running) and not stop.is_set():
        while waiting and len(running) < workers + 1:
            task, k, i = waiting.popleft()
            x = meshes[k][i] if task is solve_start else best_x[k]
            running[pool.submit(_timed, task, problems[k], x)] = (task, k, i)
        done, _ = wait(running, return_when=FIRST_COMPLETED)
        for future in done:
            task, k, i = running.pop(future)
            value, seconds = future.result()
            if task is polish:
                out[k] = (value, start_seconds[k] + seconds)
                continue
            starts[k][i], left[k] = (value, seconds), left[k] - 1
            start_seconds[k] += seconds
            if not left[k]:
                best_x[k] = best_start([fit for fit, _ in starts[k]]).x
                waiting.appendleft((polish, k, -1))
    return out


def _in_background(work: Callable[[threading.Event], dict], meanwhile: Callable[[], None] | None) -> dict:
    """``work(stop)`` on a thread of its own while ``meanwhile()`` runs here; its result, or its error raised here."""
    if meanwhile is None:
        return work(threading.Event())
    stop = threading.Event()
    box: dict[str, dict] = {}
    errors: list[BaseException] = []

    def run() -> None:
        try:
            box["value"] = work(stop)
        except BaseException as exc:  # raised in the caller's thread below
            errors.append(exc)

    thread = threading.Thread(target=run, name="sail-seed-model-fits", daemon=True)
    thread.start()
    try:
        meanwhile()
    except BaseException:
        stop.set()
        raise
    finally:
        thread.join()
    if errors:
        raise errors[0]
    return box["value"]


def _timed(fn: Callable, *args):
    """``(fn(*args), seconds)``: a pool task that says how long it took."""
    start = time.perf_counter()
    return fn(*args), time.perf_counter() - start


class _Here:
    """The pool's interface, run in this process (one worker)."""

    def submit(self, fn: Callable, *args) -> Future:
        future: Future = Future()
        future.set_result(fn(*args))
        return future


def _one_blas_thread() -> None:
    """A pool worker's initialiser: BLAS on one thread (its matrices are 27 x 27)."""
    threadpool_limits(1)


@contextmanager
def _pool(workers: int) -> Iterator:
    """A pool of ``workers`` fresh processes (spawned: nothing of this process's threads or state is forked).

    Every process, this one included while the pool runs, keeps BLAS to one thread: OpenBLAS's idle
    threads spin, and with more processes than cores they took a third more CPU (``sail reproduce``:
    90 s of user time against 69 s).
    """
    if workers <= 1:
        with threadpool_limits(1):  # the same BLAS here as in a pool: the same rounding in the standard errors
            yield _Here()
        return
    with threadpool_limits(1), ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"),
                                                   initializer=_one_blas_thread) as pool:  # fmt: skip
        try:
            yield pool
        except BaseException:
            pool.shutdown(wait=False, cancel_futures=True)
            raise


def shape(table: np.ndarray, cell: int) -> np.ndarray:
    """Cell ``cell``'s (1 or 2) amplitude over its mean: the shape, free of the signal unit."""
    a = table[:, 2 * cell - 1]
    return a / a.mean()


def interior_minimum(table: np.ndarray, cell: int) -> bool:
    """Whether the amplitude falls, then rises, with delta (the seed's shape), not monotone."""
    k = int(np.argmin(table[:, 2 * cell - 1]))
    return 0 < k < table.shape[0] - 1


@dataclass(frozen=True)
class PhasePattern:
    """The convention-free facts of a Table 4's phases: opposite signs, magnitudes growing with delta."""

    opposite_signs: bool
    growing: tuple[bool, bool]
    signs: tuple[int, int]  #: the sign of P1 and of P2 in this table's convention (0: mixed)

    @property
    def convention_free_match(self) -> bool:
        return self.opposite_signs and all(self.growing)


def phase_pattern(table: np.ndarray) -> PhasePattern:
    p1, p2 = table[:, 2], table[:, 4]
    sign = lambda p: int(np.sign(p[0])) if np.all(np.sign(p) == np.sign(p[0])) else 0
    return PhasePattern(
        opposite_signs=bool(np.all(np.sign(p1) * np.sign(p2) < 0)),
        growing=(bool(np.all(np.diff(np.abs(p1)) > 0)), bool(np.all(np.diff(np.abs(p2)) > 0))),
        signs=(sign(p1), sign(p2)),
    )


#: The variations :func:`phase_drivers` applies to a bonded robot: label, {key: factor}.
PHASE_DRIVERS = (
    ("cell compliance ÷ 10", {"loadcells.rated_deflection": 0.1}),
    ("cell compliance × 10", {"loadcells.rated_deflection": 10.0}),
    ("link E ÷ 10", {"materials.links.E": 0.1}),
    ("link E × 10", {"materials.links.E": 10.0}),
    ("l3 × 1.2", {"links.l3": 1.2}),
    ("l2 × 0.75", {"links.l2": 0.75}),
    ("cell position × 0.6", {"loadcells.position": 0.6}),
)


def phase_drivers(robot: Robot, protocol: Protocol = Protocol()) -> list[tuple[str, float, float]]:
    """(label, P1, P2) [deg] at the largest sweep delta, bonded joints: ``robot`` first, then each of :data:`PHASE_DRIVERS`."""
    bonded = with_keys(robot, {"joints.model": "bonded"})
    rows = []
    for label, factors in (("as given", {}), *PHASE_DRIVERS):
        varied = with_keys(bonded, {key: factor * float(get_key(bonded, key)) for key, factor in factors.items()})
        t = table4(varied, protocol=protocol)
        rows.append((label, float(t[-1, 2]), float(t[-1, 4])))
    return rows


@dataclass(frozen=True)
class CrosstalkCheck:
    """Pin joints with axial crosstalk ``c`` under the bridge reading (:func:`pin_crosstalk`)."""

    crosstalk: float
    a1_spread: float  #: peak-to-peak of A1 over its mean
    a1_corrected_spread: float  #: the same of A1 (1 - c cot delta): zero if the law holds
    p1_max_deg: float  #: max |P1|
    p2_range_deg: tuple[float, float]  #: min and max P2
    a2_spread: float


def pin_crosstalk(robot: Robot, crosstalk: float = 0.05, protocol: Protocol = Protocol()) -> CrosstalkCheck:
    """Table 4 of ``robot`` with pin joints and axial crosstalk ``crosstalk``, read by the bridge.

    Cell 1's axial force is N1 = -V1 cot(delta), in phase with its shear, so its
    reading V1 + c N1 = V1 (1 - c cot delta): the amplitude (torque per signal)
    varies as 1/(1 - c cot delta) and the phase stays zero.  N2 is not in phase
    with V2, so cell 2 gains a phase offset.
    """
    pin = with_keys(robot, {"joints.model": "pin", "loadcells.crosstalk_axial": crosstalk})
    t = table4(pin, "bridge", protocol=protocol)
    delta = np.radians(t[:, 0])
    a1, a2 = t[:, 1], t[:, 3]
    corrected = a1 * (1.0 - crosstalk / np.tan(delta))
    return CrosstalkCheck(
        crosstalk=crosstalk, a1_spread=float(np.ptp(a1) / a1.mean()),
        a1_corrected_spread=float(np.ptp(corrected) / corrected.mean()), p1_max_deg=float(np.abs(t[:, 2]).max()),
        p2_range_deg=(float(t[:, 4].min()), float(t[:, 4].max())), a2_spread=float(np.ptp(a2) / a2.mean()),
    )  # fmt: skip


def implied_torque_amplitudes(
    regressors: Mapping[str, tuple[float, ...] | np.ndarray],
    prescale: tuple[float, float],
    rmse_before: tuple[float, float],
    protocol: Protocol = Protocol(),
) -> tuple[float, float]:
    """The torque amplitudes F l3 and F l2 [N·m] that make pre-scaled curves miss by ``rmse_before``.

    Before compensation the pre-scaled curve of cell i is k_i s_i = (k_i / A_i) T_i(phi + P_i);
    against T_i(phi), amplitude F l, its RMS error over phi is F l |k_i/A_i e^{jP_i} - 1| / sqrt(2).
    Pooled over the validation poses of grid i (A_i, P_i from the Table 4
    ``regressors`` at their delta, in degrees), the RMSE fixes F l.
    """
    out = []
    for cell in (1, 2):
        theta1, theta2 = protocol.validation_poses(cell)
        delta_deg = np.degrees(np.asarray(theta1) - np.asarray(theta2))
        amplitude = np.polyval(regressors[f"amplitude_{cell}"], delta_deg)
        phase = np.radians(np.polyval(regressors[f"phase_{cell}_deg"], delta_deg))
        relative = np.abs(prescale[cell - 1] / amplitude * np.exp(1j * phase) - 1.0) / math.sqrt(2.0)
        out.append(rmse_before[cell - 1] / math.sqrt(float(np.mean(relative**2))))
    return out[0], out[1]


def implied_lengths(protocol: Protocol = Protocol()) -> tuple[float, float]:
    """(l3, l2) [m] the seed's own numbers imply: :func:`implied_torque_amplitudes` over the seed's force.

    An inference: it assumes the seed's RMSEs are in N·m, pooled as ours are, and
    that its regressors hold at the validation deltas (127.5 deg lies beyond its table).
    """
    before = SEED_RMSE["before"]
    a3, a2 = implied_torque_amplitudes(SEED_REGRESSORS, SEED_PRESCALE, (before["t1"], before["t2"]), protocol)
    return a3 / protocol.force_N, a2 / protocol.force_N


@dataclass(frozen=True)
class SeedModelResult:
    """Everything the report's section "What was the seed's model?" shows."""

    fits: tuple[FamilyFit, ...]
    drivers: list[tuple[str, float, float]]
    crosstalk: CrosstalkCheck
    lengths: tuple[float, float]  #: implied (l3, l2) [m]
    seed_pattern: PhasePattern

    @property
    def closest(self) -> FamilyFit:
        return min(self.fits, key=lambda f: f.score)


def seed_model_study(
    robot: Robot, protocol: Protocol = Protocol(), progress: Callable[[str], None] | None = None, *,
    workers: int = 1, while_fitting: Callable[[], None] | None = None, cache_dir: Path | None = None,
    notes: list[str] | None = None,
) -> SeedModelResult:
    """Fit :data:`FAMILIES` to the seed's Table 4 from ``robot`` and run the three checks (:func:`fit_families`' options)."""
    seed = seed_table4()
    return SeedModelResult(
        fits=fit_families(robot, seed, protocol=protocol, progress=progress, workers=workers, while_fitting=while_fitting,
                          cache_dir=cache_dir, notes=notes),
        drivers=phase_drivers(robot, protocol), crosstalk=pin_crosstalk(robot, protocol=protocol),
        lengths=implied_lengths(protocol), seed_pattern=phase_pattern(seed),
    )  # fmt: skip
