"""Identify a robot's physical parameters from measurements.

Any numeric robot-file key that enters the static sensing map can be freed
(:func:`parameter`): the joint stiffnesses, the link lengths, the cell's
position, compliance and crosstalk.  The fit is scipy's ``least_squares`` with
bounds, from several starts; scale parameters (stiffnesses, compliances) are
fitted in log space so that one fit spans decades.  Each residual evaluation is
one batched frame solve over the target's poses.

Two targets:

- :class:`sailforce.paper.Table4Target`, a seed-style Table 4 ``(n, 5)`` in
  :data:`~sailforce.paper.study.TABLE4_COLUMNS`.  Residuals: each cell's phase at each
  delta [deg]; with ``amplitude_weight`` > 0 also each amplitude divided by its
  mean over delta (its shape, free of the signal unit) times ``amplitude_weight``
  [deg per unit shape]: the default 20 weighs a 5 % shape error as 1 deg of phase.
- :class:`ReadingsTarget`, calibration rows (angles, reference force, raw
  readings).  The reading of cell i is modelled as ``o_i + g_i s_i``, with s_i the
  frame's signal (``transduction``) for the row's force; the offsets and gains
  enter linearly and are solved in closed form at each step (variable
  projection), so only the physical parameters are iterated.  Residuals are in
  each cell's reading unit divided by that cell's reading spread, so two cells
  in different units weigh alike.

Uncertainty: standard errors from the Jacobian at the optimum, cov = s^2 (J^T J)^-1
with s^2 = |r|^2 / (m - n), in the fitted coordinates (log or linear), with the
offsets and gains included for a readings target so that a gain that trades
against a compliance is seen; correlations; and a flag on each parameter whose
effect is nearly a combination of the others' (multiple correlation above
:data:`CORRELATION_LIMIT`), whose relative error exceeds 1, or that the data
do not see at all.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ..errors import IdentifyError, RobotFileError, SailError
from ..fem.model import build_model
from ..fem.response import TRANSDUCTIONS, simulate_model
from ..io.robotkeys import get_key, robot_keys, with_keys
from ..robot import JOINT_NAMES, Robot
from ..sensing.maps import rotation

#: Default weight of the amplitude shape against the phases [deg per unit of A / mean(A)].
AMPLITUDE_WEIGHT = 20.0
#: Stiffness bounds [N m/rad]: from a joint that carries almost no moment to one stiffer than the links.
STIFFNESS_BOUNDS = (1e-2, 1e7)
#: Link lengths and section sizes may move within this factor of their starting value.
LENGTH_FACTOR = 2.0
#: Compliances, moduli and other scales may move within this factor of their starting value.
SCALE_FACTOR = 10.0
#: Bounds of the crosstalk coefficients (output per rated output, per unit normalised load).
CROSSTALK_BOUNDS = (-0.5, 0.5)
#: Bounds of the cell's position along its link (fraction of the link from B) ...
POSITION_BOUNDS = (0.05, 0.95)
#: ... narrowed so that the gap's centre stays this many half-gap lengths from either end of the shorter link.
POSITION_MARGIN = 1.05
#: A multiple correlation above this, or a relative standard error above 1, marks a parameter as not identifiable.
CORRELATION_LIMIT = 0.99
#: A Jacobian column below this (relative to the largest) means the data do not see the parameter at all.
INSENSITIVE = 1e-9
#: A value within this fraction of a bound (of the bound's size) ended on it.
AT_BOUND_RTOL = 1e-6
#: Starts per parameter of the multi-start grid, log-spaced (or evenly spaced) across the bounds ...
STARTS = 4
#: ... but never more than this many in all: beyond it, a Latin hypercube sample of this size (seeded: the same
#: starts every run).
MAX_STARTS = 16
SAMPLE_SEED = 12
#: Solver tolerances (scipy's xtol, ftol, gtol) of the polish from the best start: far below any
#: measurement's resolution ...
SOLVER_TOL = 1e-12
#: ... and of each start, which only has to find the right basin: to this tolerance, or within this many evaluations.
START_TOL = 1e-6
START_MAX_NFEV = 30
#: Keys that do not enter the static sensing map: freeing them is refused.
STATICALLY_INERT = ("rho", "yield_strength", "handle.", "plane.", "links.l4", "noise_mV_V", "adc.")
#: More distinct deltas than this in a readings target: interpolate the frame's map on Chebyshev nodes.
MAX_EXACT_DELTAS = 128
#: Chebyshev nodes of that interpolation (the map is analytic in delta: the error is far below 1e-9).
INTERPOLATION_NODES = 48



@dataclass(frozen=True)
class Parameter:
    """One free robot-file key, its bounds and the coordinate it is fitted in."""

    key: str
    low: float
    high: float
    log: bool  #: fitted as log(value) (scales spanning decades) rather than the value

    def to_x(self, value: float) -> float:
        return math.log(value) if self.log else (value - self.low) / (self.high - self.low)

    def from_x(self, x: float) -> float:
        return math.exp(x) if self.log else self.low + x * (self.high - self.low)

    @property
    def x_bounds(self) -> tuple[float, float]:
        return (self.to_x(self.low), self.to_x(self.high))


def parameter(robot: Robot, key: str, bounds: tuple[float, float] | None = None) -> Parameter:
    """The :class:`Parameter` for ``key`` on ``robot``, with default bounds (module constants) unless given."""
    try:
        value = get_key(robot, key)
    except SailError:
        raise IdentifyError(f"unknown parameter {key!r}: expected a numeric robot-file key, such as "
                            f"{', '.join(parameter_names(robot)[:8])} ...") from None  # fmt: skip
    if isinstance(value, str) or any(part in key for part in STATICALLY_INERT):
        why = "is a name, not a number" if isinstance(value, str) else "does not enter the static sensing map"
        raise IdentifyError(f"parameter {key!r} {why}: it cannot be identified from static measurements")
    value = float(value)
    name = key.rsplit(".", 1)[-1]
    log = True
    if name == "stiffness":
        default = STIFFNESS_BOUNDS
    elif key.startswith("links.") or key.startswith("sections.") or name in ("length", "depth", "thickness"):
        default, log = (value / LENGTH_FACTOR, value * LENGTH_FACTOR), False
    elif name == "position":  # and the cell's gap must stay inside both driven links
        margin = POSITION_MARGIN * robot.loadcell.length / 2 / min(robot.arm.l1, robot.arm.l2)
        default, log = (max(POSITION_BOUNDS[0], margin), min(POSITION_BOUNDS[1], 1.0 - margin)), False
    elif name.startswith("crosstalk"):
        default, log = CROSSTALK_BOUNDS, False
    elif name == "compliance_vm":
        reach = SCALE_FACTOR * abs(value) or math.sqrt(robot.loadcell.compliance_vv * robot.loadcell.compliance_mm)
        default, log = (-reach, reach), False
    else:
        default = (value / SCALE_FACTOR, value * SCALE_FACTOR)
    low, high = (float(b) for b in (bounds if bounds is not None else default))
    if not (math.isfinite(low) and math.isfinite(high) and low < high) or (log and low <= 0):
        raise IdentifyError(f"bounds {low:g}..{high:g} for {key!r}: expected finite low < high"
                            + (", both positive (it is fitted in log space)" if log else ""))  # fmt: skip
    return Parameter(key, low, high, log)


def parameter_names(robot: Robot) -> tuple[str, ...]:
    """Every robot-file key that can be freed on ``robot``."""
    return tuple(k for k in robot_keys(robot, numeric=True) if not any(p in k for p in STATICALLY_INERT))


def with_parameter(robot: Robot, name: str, value: float) -> Robot:
    """A copy of ``robot`` with the parameter ``name`` set to ``value``."""
    parameter(robot, name)
    return with_keys(robot, {name: float(value)})


def get_parameter(robot: Robot, name: str) -> float:
    """The value of the parameter ``name`` on ``robot``."""
    parameter(robot, name)
    return float(get_key(robot, name))


def with_free_springs(robot: Robot, free: Sequence[str]) -> Robot:
    """``robot`` with every joint whose stiffness is in ``free`` made a spring, so that the fit spans pin to bonded.

    A pin or bonded joint ignores its stiffness: freeing it would fit nothing.  The shared
    ``joints.stiffness`` changes the shared model only; per-joint tables keep theirs.
    """
    out = robot
    for key in free:
        parts = key.split(".")
        if parts[0] != "joints" or parts[-1] != "stiffness" or (len(parts) == 3 and parts[1] not in JOINT_NAMES):
            continue  # not a joint's stiffness (an unknown joint is refused by name when the fit starts)
        if len(parts) == 2:  # the shared joint: the per-joint tables, if any, keep their own models
            changes = {"joints.model": "spring"} if out.joints.model != "spring" else {}
        else:
            changes = {f"{parts[0]}.{parts[1]}.model": "spring"} if out.joints.at(parts[1]).model != "spring" else {}
        if changes:
            out = with_keys(out, changes)
    return out


# --- targets -------------------------------------------------------------------------------------------------


def _rms2(a: np.ndarray) -> tuple[float, float]:
    r = np.sqrt(np.mean(np.asarray(a) ** 2, axis=0))
    return float(r[0]), float(r[1])


def sensing_map(robot: Robot, delta, transduction: str = "deflection") -> np.ndarray:
    """S0(delta), ``(..., 2, 2)``: each cell's signal per unit force at theta2 = 0 (one batched frame solve).

    At any pose the map is S0(delta) R(-theta2): the frame turns rigidly with the
    arm (docs/errata.md, Physics).
    """
    delta = np.asarray(delta, dtype=float)
    return simulate_model(build_model(robot), delta, np.zeros_like(delta)).signal(transduction)


@dataclass(frozen=True)
class ReadingsTarget:
    """Calibration rows to match: angles [rad], reference force [N], raw readings (any linear unit)."""

    theta1: np.ndarray
    theta2: np.ndarray
    fx: np.ndarray
    fy: np.ndarray
    load1: np.ndarray
    load2: np.ndarray
    transduction: str = "deflection"

    columns = ("cell 1 / spread", "cell 2 / spread")

    def __post_init__(self) -> None:
        if self.transduction not in TRANSDUCTIONS:
            raise IdentifyError(f"transduction = {self.transduction!r}: expected one of {', '.join(TRANSDUCTIONS)}")
        arrays = [np.ravel(np.asarray(getattr(self, n), dtype=float)) for n in ("theta1", "theta2", "fx", "fy", "load1", "load2")]
        if len({a.size for a in arrays}) != 1 or arrays[0].size < 8:
            raise IdentifyError("a readings target needs at least 8 rows, with every column the same length")
        if not all(np.isfinite(a).all() for a in arrays):
            raise IdentifyError("a readings target must be finite: remove the rows with NaN or infinity first")
        for name, a in zip(("theta1", "theta2", "fx", "fy", "load1", "load2"), arrays):
            object.__setattr__(self, name, a)
        # what does not change between evaluations, computed once: the forces in link 2's frame, and the
        # deltas at which the frame is solved with the matrix that takes the solutions to every row
        force = (rotation(-self.theta2) @ np.stack([self.fx, self.fy], axis=-1)[..., None])[..., 0]
        delta = self.delta
        unique = np.unique(delta)
        if unique.size <= MAX_EXACT_DELTAS:
            nodes, weights = unique, None
            index = np.searchsorted(unique, delta)
        else:
            low, high = float(delta.min()), float(delta.max())
            x_nodes = np.polynomial.chebyshev.chebpts2(INTERPOLATION_NODES)
            nodes = low + (x_nodes + 1.0) * (high - low) / 2.0
            to_series = np.linalg.inv(np.polynomial.chebyshev.chebvander(x_nodes, INTERPOLATION_NODES - 1))
            weights = np.polynomial.chebyshev.chebvander((2.0 * delta - (low + high)) / (high - low), INTERPOLATION_NODES - 1) @ to_series
            index = None
        object.__setattr__(self, "_plan", (force, nodes, index, weights))

    @property
    def delta(self) -> np.ndarray:
        return self.theta1 - self.theta2

    @property
    def spread(self) -> np.ndarray:
        """Each cell's reading spread (standard deviation), the residuals' unit."""
        return np.maximum(np.std([self.load1, self.load2], axis=1), np.finfo(float).tiny)

    def signals(self, robot: Robot) -> np.ndarray:
        """(n, 2): the frame's signal of each cell for each row's force."""
        force, nodes, index, weights = self._plan  # type: ignore[attr-defined]
        at_nodes = sensing_map(robot, nodes, self.transduction)  # one batched solve
        maps = at_nodes[index] if weights is None else (weights @ at_nodes.reshape(-1, 4)).reshape(-1, 2, 2)
        return (maps @ force[..., None])[..., 0]

    def linear(self, signals: np.ndarray) -> np.ndarray:
        """(2, 2): each cell's (offset, gain) minimising its squared residual for these signals."""
        out = np.zeros((2, 2))
        for i, load in enumerate((self.load1, self.load2)):
            design = np.column_stack([np.ones_like(load), signals[:, i]])
            out[i] = np.linalg.lstsq(design, load, rcond=None)[0]
        return out

    def residuals(self, robot: Robot, linear: np.ndarray | None = None) -> np.ndarray:
        """(n, 2): reading minus model, over each cell's spread; offsets and gains projected unless given."""
        signals = self.signals(robot)
        og = self.linear(signals) if linear is None else linear
        model = og[:, 0] + og[:, 1] * signals
        return (np.column_stack([self.load1, self.load2]) - model) / self.spread

    def metrics(self, residuals: np.ndarray) -> dict[str, tuple[float, float]]:
        spread = self.spread
        return {"rms_reading": _rms2(residuals * spread)}


# --- the fit -------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Identification:
    """The fitted parameters, their uncertainty, and the residuals row by row."""

    robot: Robot  #: the robot with the identified values
    names: tuple[str, ...]  #: the free keys, then (readings target) offset1, gain1, offset2, gain2
    values: np.ndarray  #: (n_params,)
    standard_errors: np.ndarray  #: (n_params,)
    correlation: np.ndarray  #: (n_params, n_params)
    identifiable: np.ndarray  #: (n_params,) bool
    collinearity: np.ndarray  #: (n_params,) multiple correlation of each parameter's effect with all the others'
    residuals: np.ndarray  #: (n_rows, n_columns), columns named by ``residual_columns``
    residual_columns: tuple[str, ...]
    metrics: dict[str, tuple[float, float]]  #: per cell: phase_rms_deg and shape_rms, or rms_reading
    bounds: tuple[tuple[float, float], ...]  #: of the free keys
    starts: int
    success: bool

    @property
    def phase_rms_deg(self) -> tuple[float, float]:
        return self.metrics.get("phase_rms_deg", (math.nan, math.nan))

    @property
    def shape_rms(self) -> tuple[float, float]:
        return self.metrics.get("shape_rms", (math.nan, math.nan))

    @property
    def offsets(self) -> np.ndarray:
        """(2,) the readings' offsets (readings target only)."""
        return self.values[[self.names.index("offset1"), self.names.index("offset2")]]

    @property
    def gains(self) -> np.ndarray:
        """(2,) reading per unit of the frame's signal (readings target only)."""
        return self.values[[self.names.index("gain1"), self.names.index("gain2")]]

    def at_bound(self) -> tuple[str, ...]:
        """The free keys that ended on a bound (within :data:`AT_BOUND_RTOL` of it): the data push beyond the range allowed."""
        out = []
        for name, value, (low, high) in zip(self.names, self.values, self.bounds):
            span = high - low
            if any(abs(value - b) <= AT_BOUND_RTOL * max(abs(b), AT_BOUND_RTOL * span) for b in (low, high)):
                out.append(name)
        return tuple(out)


class Target(Protocol):
    """What :func:`identify` fits: residuals of a robot, and the metrics of a residual.

    :class:`ReadingsTarget` here; :class:`sailforce.paper.Table4Target` for a seed-style Table 4.
    """

    @property
    def columns(self) -> tuple[str, ...]: ...

    def residuals(self, robot: Robot) -> np.ndarray: ...

    def metrics(self, residuals: np.ndarray) -> dict[str, tuple[float, float]]: ...


@dataclass(frozen=True)
class Problem:
    """One identification, ready to solve: the robot (free joints made springs), the target, the free parameters.

    Picklable, so that its starts can be solved in other processes (:func:`solve_start`,
    :func:`sailforce.paper.seed_model.fit_families`).  Made by :func:`prepare`.
    """

    robot: Robot
    target: Target
    params: tuple[Parameter, ...]

    @property
    def free(self) -> tuple[str, ...]:
        return tuple(p.key for p in self.params)

    @property
    def x_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return np.array([p.x_bounds[0] for p in self.params]), np.array([p.x_bounds[1] for p in self.params])

    def robot_at(self, x: np.ndarray) -> Robot:
        return with_keys(self.robot, {p.key: p.from_x(v) for p, v in zip(self.params, x)})

    def residuals(self, x: np.ndarray) -> np.ndarray:
        return self.target.residuals(self.robot_at(x)).ravel()

    def residuals_map(self, fun: Callable, points: Iterable[np.ndarray]) -> list[np.ndarray]:
        """``[fun(x) for x in points]``, as least_squares' ``workers`` asks for its finite-difference Jacobian's columns.

        ``fun`` is :meth:`residuals`; a target with ``residuals_many`` (a Table 4) evaluates
        every column's robot in one stacked frame solve instead.
        """
        many = getattr(self.target, "residuals_many", None)
        if many is None:
            return [fun(x) for x in points]
        return [r.ravel() for r in many([self.robot_at(x) for x in points])]

    def starts(self, per_parameter: int | None = None) -> np.ndarray:
        """``(n_starts, n)``: the robot's own values (clipped to the bounds), then :func:`_starts`' grid or sample."""
        low, high = self.x_bounds
        first = np.clip([p.to_x(float(get_key(self.robot, p.key))) for p in self.params], low, high)
        return np.vstack([first, _starts(low, high, STARTS if per_parameter is None else int(per_parameter))])


def prepare(robot: Robot, target: Target, free: Sequence[str],
            bounds: Mapping[str, tuple[float, float]] | None = None) -> Problem:  # fmt: skip
    """The :class:`Problem` of fitting ``free`` on ``robot`` to ``target``; a target that does not fit is refused here."""
    free = tuple(dict.fromkeys(free))
    if not free:
        raise IdentifyError("nothing to fit: name at least one parameter in free")
    bounds = dict(bounds or {})
    unknown = sorted(set(bounds) - set(free))
    if unknown:
        raise IdentifyError(f"bounds given for {', '.join(unknown)}, which is not free")
    robot = with_free_springs(robot, free)
    params = tuple(parameter(robot, key, bounds.get(key)) for key in free)
    target.residuals(robot)  # a target that does not fit the robot (another delta grid ...) is refused here, once
    return Problem(robot, target, params)


def solve_start(problem: Problem, x0: np.ndarray):
    """One start, solved to :data:`START_TOL` (at most :data:`START_MAX_NFEV` evaluations); None if its robot is invalid."""
    least_squares = _least_squares()
    try:
        return least_squares(problem.residuals, x0, bounds=problem.x_bounds, xtol=START_TOL, ftol=START_TOL,
                             gtol=START_TOL, max_nfev=START_MAX_NFEV, workers=problem.residuals_map)  # fmt: skip
    except RobotFileError:  # a start whose robot is invalid (a cell that no longer fits ...): skip it
        return None


def best_start(results):
    """The lowest-cost start (the first of equals), refused if none gave a valid robot."""
    best = None
    for fit in results:
        if fit is not None and (best is None or fit.cost < best.cost):
            best = fit
    if best is None:
        raise IdentifyError("no start gave a valid robot: narrow the bounds")
    return best


def polish(problem: Problem, x: np.ndarray):
    """The best start solved on to :data:`SOLVER_TOL`."""
    return _least_squares()(problem.residuals, x, bounds=problem.x_bounds, xtol=SOLVER_TOL, ftol=SOLVER_TOL, gtol=SOLVER_TOL,
                         workers=problem.residuals_map)  # fmt: skip


def identify(
    robot: Robot,
    target: Target,
    free: Sequence[str],
    *,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    starts: int | None = None,
    polish: bool = True,
    progress: Callable[[int, int], None] | None = None,
) -> Identification:
    """Fit the ``free`` robot-file keys of ``robot`` so that its model matches ``target``.

    The other keys keep ``robot``'s values; a joint whose stiffness is free
    becomes a spring (:func:`with_free_springs`).  Starts: ``robot``'s own values, then
    a grid of ``starts`` per parameter (:data:`STARTS`), or a Latin hypercube sample
    of :data:`MAX_STARTS` when that grid is larger.  Each start is solved to
    :data:`START_TOL` and the best polished to :data:`SOLVER_TOL` (unless not
    ``polish``: cross-validation's refits).  Stopping once a few starts agree was
    tried and dropped: three starts can agree on a local minimum where a gain
    trades against a stiffness.  ``progress(done, total)`` is called after each start.

    The steps (:func:`prepare`, :func:`solve_start`, :func:`best_start`,
    :func:`polish`, :func:`conclude`) are public so that many fits can share a
    pool of processes: :func:`sailforce.paper.seed_model.fit_families`.
    """
    problem = prepare(robot, target, free, bounds)
    mesh = problem.starts(starts)
    results = []
    for tried, x0 in enumerate(mesh, start=1):
        results.append(solve_start(problem, x0))
        if progress is not None:
            progress(tried, len(mesh))
    best = best_start(results)
    return conclude(problem, _polish(problem, best.x) if polish else best, len(mesh))


_polish = polish  # identify's keyword ``polish`` shadows the step inside it


def conclude(problem: Problem, best, n_starts: int) -> Identification:
    """The :class:`Identification` at the solver's result ``best``: values, uncertainty, residuals."""
    target, params, free = problem.target, problem.params, problem.free
    fitted = problem.robot_at(best.x)
    values = np.array([p.from_x(v) for p, v in zip(params, best.x)])
    names: tuple[str, ...] = free
    log = np.array([p.log for p in params])
    jac, fun = np.ascontiguousarray(best.jac), np.asarray(best.fun)  # one memory order: the same rounding as a cached copy
    if isinstance(target, ReadingsTarget):
        linear = target.linear(target.signals(fitted))
        jac, fun = _full_jacobian(target, problem.robot_at, best.x, linear)
        names = (*free, "offset1", "gain1", "offset2", "gain2")
        values = np.concatenate([values, linear.ravel()])
        log = np.concatenate([log, np.zeros(4, dtype=bool)])
    typical = np.array([1.0 if p.log else p.high - p.low for p in params])
    if isinstance(target, ReadingsTarget):  # an offset's natural size is the reading spread, a gain's its value
        typical = np.concatenate([typical, np.ravel(np.column_stack([target.spread, np.abs(linear[:, 1])]))])
    standard_errors, correlation, identifiable, collinearity = _uncertainty(jac, fun, values, log, typical)
    final = target.residuals(fitted)
    return Identification(
        robot=fitted, names=names, values=values, standard_errors=standard_errors, correlation=correlation,
        identifiable=identifiable, collinearity=collinearity, residuals=final, residual_columns=target.columns[: final.shape[1]],
        metrics=target.metrics(final), bounds=tuple((p.low, p.high) for p in params),
        starts=n_starts, success=bool(best.success),
    )  # fmt: skip


def _least_squares():
    """scipy's least_squares, imported when a fit runs: scipy.optimize takes over half a second to import, and this
    module is loaded by every command that reads a calibration."""
    from scipy.optimize import least_squares

    return least_squares


def _starts(low: np.ndarray, high: np.ndarray, per_parameter: int) -> np.ndarray:
    """Interior grid points of the box, or a Latin hypercube sample when the grid would exceed MAX_STARTS.

    The sample puts one start in each of MAX_STARTS equal slices of every
    parameter's range (McKay, Beckman & Conover 1979), at a seeded random
    place within it and in a seeded random pairing across parameters.  It is
    written here rather than taken from ``scipy.stats.qmc``: importing
    scipy.stats costs 0.7-1.0 s, a fifth of ``sail calibrate``.
    """
    n = low.size
    if per_parameter < 1:
        return np.empty((0, n))
    if per_parameter**n <= MAX_STARTS:
        grid = np.linspace(0.0, 1.0, per_parameter + 2)[1:-1]
        unit = np.stack(np.meshgrid(*([grid] * n), indexing="ij"), axis=-1).reshape(-1, n)
    else:
        rng = np.random.default_rng(SAMPLE_SEED)
        unit = (rng.permuted(np.tile(np.arange(MAX_STARTS), (n, 1)), axis=1).T + rng.random((MAX_STARTS, n))) / MAX_STARTS
    return low + unit * (high - low)


def _full_jacobian(target: ReadingsTarget, robot_at, x: np.ndarray, linear: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Jacobian of the residuals in (x, offsets, gains) with the offsets and gains held, and the residuals."""
    fun = target.residuals(robot_at(x), linear).ravel()
    columns = []
    for k in range(x.size):
        step = 1e-6 * max(1.0, abs(x[k]))
        up, down = x.copy(), x.copy()
        up[k] += step
        down[k] -= step
        columns.append((target.residuals(robot_at(up), linear).ravel() - target.residuals(robot_at(down), linear).ravel())
                       / (2.0 * step))  # fmt: skip
    signals = target.signals(robot_at(x))
    spread = target.spread
    for i in range(2):  # d(residual)/d(offset_i) = -1 / spread_i, d/d(gain_i) = -s_i / spread_i, on cell i's column
        for column in (np.ones(signals.shape[0]), signals[:, i]):
            full = np.zeros_like(signals)
            full[:, i] = -column / spread[i]
            columns.append(full.ravel())
    return np.column_stack(columns), fun


def _uncertainty(jac: np.ndarray, fun: np.ndarray, values: np.ndarray, log: np.ndarray,
                 typical: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """Standard errors (cov = s^2 (J^T J)^-1 in the fitted coordinates), correlations, identifiability, collinearity.

    A parameter is not identifiable when its effect is, to :data:`CORRELATION_LIMIT`, a
    combination of the others' (its multiple correlation: a pairwise correlation misses a
    shared compliance that trades against both gains at once), when its relative standard
    error exceeds 1, or when it is unseen.

    A parameter is unseen when moving it by its ``typical`` size moves the
    residuals by less than :data:`INSENSITIVE` of what the most visible one does.
    """
    m, n = jac.shape
    norms = np.linalg.norm(jac, axis=0)
    effect = norms * typical
    seen = effect > INSENSITIVE * max(effect.max(), np.finfo(float).tiny)
    s2 = float(fun @ fun) / max(m - n, 1)
    covariance = np.full((n, n), np.nan)
    if seen.any():
        sub = jac[:, seen] / norms[seen]  # columns scaled to unit length: the pseudo-inverse sees the geometry only
        covariance[np.ix_(seen, seen)] = s2 * np.linalg.pinv(sub.T @ sub) / np.outer(norms[seen], norms[seen])
    coordinate_se = np.sqrt(np.abs(np.diag(covariance)))
    scale = np.where(log, np.abs(values), 1.0)  # d(value) = value d(log value)
    standard_errors = scale * coordinate_se
    outer = np.outer(coordinate_se, coordinate_se)
    with np.errstate(invalid="ignore", divide="ignore"):
        correlation = np.where(outer > 0, covariance / outer, np.eye(n))
    correlation[np.isnan(correlation)] = 0.0
    np.fill_diagonal(correlation, 1.0)
    collinearity = np.full(n, np.nan)
    if seen.any():  # multiple correlation R_k of column k with all the others: R_k^2 = 1 - 1 / [(S^T S)^-1]_kk
        sub = jac[:, seen] / norms[seen]
        inverse_diagonal = np.diag(np.linalg.pinv(sub.T @ sub))
        with np.errstate(divide="ignore"):
            collinearity[seen] = np.sqrt(np.clip(1.0 - 1.0 / np.maximum(inverse_diagonal, 1.0), 0.0, 1.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        relative = standard_errors / np.abs(values)
    identifiable = seen & ~(collinearity > CORRELATION_LIMIT) & ~(relative > 1.0)
    return standard_errors, correlation, identifiable, collinearity
