"""Identify a robot's physical parameters from a target Table 4 (issue 12): work in progress.

What is here: the joint stiffnesses (``joints.stiffness``, ``joints.P1.stiffness`` ...) fitted to
a Table 4 (phases directly, amplitudes by their shape) with scipy's ``least_squares`` from several
starts, in log-stiffness so that the fit spans decades; standard errors and correlations from the
Jacobian at the optimum, and a flag on what the data cannot identify.  Not yet here: lengths, the
cell's compliance and crosstalk as parameters, calibration recordings as targets, ``sail identify``.

Residuals (for a target ``(n, 5)`` in :data:`~sailforce.study.TABLE4_COLUMNS`):

- the phase of each cell at each delta [deg];
- with ``amplitude_weight`` > 0, each cell's amplitude divided by its mean over delta (its shape,
  free of the signal unit), times ``amplitude_weight`` [deg per unit shape]: the default 20 makes
  a 5 % shape error weigh as much as 1 deg of phase.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import least_squares

from .errors import SailError
from .robot import JOINT_NAMES, Robot
from .study import Protocol, table4

#: Default weight of the amplitude shape against the phases [deg per unit of A / mean(A)].
AMPLITUDE_WEIGHT = 20.0
#: Stiffness bounds [N m/rad]: from a joint that carries almost no moment to one stiffer than the links.
STIFFNESS_BOUNDS = (1e-2, 1e7)
#: |correlation| above this, or a relative standard error above 1, marks a parameter as not identifiable.
CORRELATION_LIMIT = 0.99
#: A Jacobian column below this (relative to the largest) means the data do not see the parameter at all.
INSENSITIVE = 1e-9
#: Starts per parameter of the multi-start, log-spaced across the bounds.
STARTS = 4


class IdentifyError(SailError):
    """A parameter sailforce cannot fit, or a target it cannot fit to."""


def parameter_names(robot: Robot) -> tuple[str, ...]:
    """Every parameter :func:`identify_table4` can free on ``robot``."""
    del robot
    return ("joints.stiffness", *(f"joints.{name}.stiffness" for name in JOINT_NAMES))


def _joint_of(robot: Robot, name: str) -> str:
    """``""`` for ``joints.stiffness`` (the shared joint), ``"P1"`` for ``joints.P1.stiffness`` ..."""
    parts = name.split(".")
    if parts == ["joints", "stiffness"]:
        return ""
    if len(parts) == 3 and parts[0] == "joints" and parts[1] in JOINT_NAMES and parts[2] == "stiffness":
        return parts[1]
    raise IdentifyError(f"unknown parameter {name!r}: expected one of {', '.join(parameter_names(robot))}")


def with_parameter(robot: Robot, name: str, value: float) -> Robot:
    """A copy of ``robot`` with the parameter ``name`` (see :func:`parameter_names`) set to ``value``."""
    joint = _joint_of(robot, name)
    if not joint:
        return replace(robot, joints=replace(robot.joints, stiffness=float(value)))
    own = replace(robot.joints.at(joint), stiffness=float(value))
    return replace(robot, joints=replace(robot.joints, **{joint: own}))


def get_parameter(robot: Robot, name: str) -> float:
    """The value of the parameter ``name`` on ``robot``."""
    joint = _joint_of(robot, name)
    return float(robot.joints.at(joint).stiffness if joint else robot.joints.stiffness)


@dataclass(frozen=True)
class Identification:
    """The fitted parameters, their uncertainty, and the residuals row by row."""

    robot: Robot  #: the robot with the identified values
    names: tuple[str, ...]
    values: np.ndarray  #: (n_params,)
    standard_errors: np.ndarray  #: (n_params,), from the residuals' spread and the Jacobian
    correlation: np.ndarray  #: (n_params, n_params)
    identifiable: np.ndarray  #: (n_params,) bool
    residuals: np.ndarray  #: (n_delta, 4): phase 1, phase 2 [deg], shape 1, shape 2 (weighted)
    phase_rms_deg: tuple[float, float]
    shape_rms: tuple[float, float]  #: RMS of A_i / mean(A_i) against the target's
    starts: int
    success: bool


def table4_residuals(model: np.ndarray, target: np.ndarray, amplitude_weight: float = AMPLITUDE_WEIGHT) -> np.ndarray:
    """(n, 4) residuals: both phases [deg], then both amplitude shapes times ``amplitude_weight``."""
    if model.shape != target.shape or not np.allclose(model[:, 0], target[:, 0]):
        raise IdentifyError(f"the target's Table 4 has delta = {target[:, 0].tolist()} deg; the protocol's sweeps "
                            f"give {model[:, 0].tolist()}: give a Protocol with the target's grid")  # fmt: skip
    phases = model[:, [2, 4]] - target[:, [2, 4]]
    shape = lambda t: t[:, [1, 3]] / np.mean(t[:, [1, 3]], axis=0)
    return np.column_stack([phases, amplitude_weight * (shape(model) - shape(target))])


def identify_table4(
    robot: Robot,
    target: np.ndarray,
    free: Sequence[str],
    *,
    transduction: str = "deflection",
    amplitude_weight: float = AMPLITUDE_WEIGHT,
    bounds: tuple[float, float] = STIFFNESS_BOUNDS,
    protocol: Protocol = Protocol(),
    starts: int = STARTS,
) -> Identification:
    """Fit the ``free`` parameters of ``robot`` so that its Table 4 matches ``target``.

    The other parameters keep ``robot``'s values.  Each stiffness is fitted in log space
    within ``bounds``; the best of ``starts`` ** len(free) starts (at most 64) is kept.
    """
    free = tuple(free)
    if not free:
        raise IdentifyError("nothing to fit: name at least one parameter in free")
    for name in free:
        get_parameter(robot, name)
    target = np.asarray(target, dtype=float)
    weight = amplitude_weight

    def robot_at(log_k: np.ndarray) -> Robot:
        fitted = robot
        for name, value in zip(free, np.exp(log_k)):
            fitted = with_parameter(fitted, name, value)
        return fitted

    def residuals(log_k: np.ndarray) -> np.ndarray:
        columns = table4_residuals(table4(robot_at(log_k), transduction, protocol=protocol), target, weight)
        return (columns if weight > 0 else columns[:, :2]).ravel()

    low, high = np.log(bounds[0]), np.log(bounds[1])
    grid = np.linspace(low, high, starts + 2)[1:-1]
    mesh = np.stack(np.meshgrid(*([grid] * len(free)), indexing="ij"), axis=-1).reshape(-1, len(free))
    mesh = mesh[:: max(1, math.ceil(len(mesh) / 64))]
    best = None
    for x0 in mesh:
        fit = least_squares(residuals, x0, bounds=(low, high), x_scale=1.0, xtol=1e-12, ftol=1e-12, gtol=1e-12)
        if best is None or fit.cost < best.cost:
            best = fit
    assert best is not None
    fitted = robot_at(best.x)
    values = np.exp(best.x)
    standard_errors, correlation, identifiable = _uncertainty(best.jac, best.fun, values)
    final = table4_residuals(table4(fitted, transduction, protocol=protocol), target, weight)
    return Identification(
        robot=fitted, names=free, values=values, standard_errors=standard_errors, correlation=correlation,
        identifiable=identifiable, residuals=final,
        phase_rms_deg=tuple(float(v) for v in np.sqrt(np.mean(final[:, :2] ** 2, axis=0))),
        shape_rms=tuple(float(v) for v in np.sqrt(np.mean((final[:, 2:] / weight) ** 2, axis=0))) if weight > 0
        else (math.nan, math.nan),
        starts=len(mesh), success=bool(best.success),
    )  # fmt: skip


def _uncertainty(jac: np.ndarray, fun: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Standard errors (cov = s^2 (J^T J)^-1 in log space, s^2 = |r|^2 / (m - n)), correlations, identifiability."""
    m, n = jac.shape
    norms = np.linalg.norm(jac, axis=0)
    seen = norms > INSENSITIVE * max(norms.max(), np.finfo(float).tiny)
    s2 = float(fun @ fun) / max(m - n, 1)
    covariance = np.full((n, n), np.nan)
    if seen.any():
        sub = jac[:, seen]
        covariance[np.ix_(seen, seen)] = s2 * np.linalg.pinv(sub.T @ sub)
    log_se = np.sqrt(np.abs(np.diag(covariance)))
    standard_errors = values * log_se
    scale = np.outer(log_se, log_se)
    with np.errstate(invalid="ignore", divide="ignore"):
        correlation = np.where(scale > 0, covariance / scale, np.eye(n))
    correlation[np.isnan(correlation)] = 0.0
    np.fill_diagonal(correlation, 1.0)
    strongly = np.abs(correlation - np.eye(n)).max(axis=1, initial=0.0) > CORRELATION_LIMIT
    identifiable = seen & ~strongly & ~(log_se > 1.0)
    return standard_errors, correlation, identifiable
