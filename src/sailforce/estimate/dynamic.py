"""The dynamic term of a calibration: identified from a free-motion recording, subtracted while the arm moves.

Readings model, for a calibration's sensing map ``M`` (``s = M F`` at rest)::

    s - offsets = M F + G V_dyn,     G = M (J^T)^-1 diag(l1, l2)

``V_dyn = Y(q, qd, qdd) beta`` are the cells' inertial and gravity shears
(:mod:`sailforce.motion.dynamics`, base parameters ``beta``) and ``G`` turns a
shear into readings the way the static map turns the shears ``T_i / l_i``
of a force into readings (exact for pin joints).  So the estimate while
moving is ``F = M^-1 (s - offsets) - (J^T)^-1 diag(l) V_dyn``.

With nobody holding the handle (``F = 0``), the readings are ``G Y beta``
alone: a linear least-squares problem for ``beta`` (:func:`fit_dynamic_term`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..kernel import inverse_entries, matrix, torque_entries
from ..motion.differentiate import (
    Differentiator,
    RatePlan,
    RateTracker,
)
from ..motion.dynamics import PARAMETERS, ShearModel
from .estimator import estimate_moving_blocks, estimate_with_rates


@dataclass(frozen=True)
class DynamicTerm:
    """Identified base parameters (``values`` in :data:`sailforce.motion.dynamics.PARAMETERS` ``columns``) and the differentiator."""

    columns: tuple[int, ...]
    values: tuple[float, ...]
    differentiator: Differentiator = Differentiator()
    combinations: tuple[str, ...] = ()  #: what each value stands for, e.g. ``l4.hx + 1.5 l3.hx`` (for people)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(PARAMETERS[c] for c in self.columns)

    def parameters(self) -> np.ndarray:
        """A full parameter vector (20,) equivalent to the base parameters for every motion."""
        pi = np.zeros(len(PARAMETERS))
        pi[list(self.columns)] = self.values
        return pi

    def shear_model(self, arm) -> ShearModel:
        """The closed-form shears of these base parameters on ``arm``."""
        return ShearModel.from_parameters(arm, self.parameters())


def reading_gain(model, arm, theta1, theta2) -> np.ndarray:
    """``G = M (J^T)^-1 diag(l1, l2)`` ``(n, 2, 2)``: readings per newton of shear in each cell."""
    s1, c1, s2, c2 = np.sin(theta1), np.cos(theta1), np.sin(theta2), np.cos(theta2)
    jt = torque_entries(arm.l2, arm.l3, s1, c1, s2, c2)
    m = model.sensing_entries(theta1 - theta2, jt)
    return matrix(m) @ matrix(inverse_entries(jt)) * np.array([arm.l1, arm.l2])


def motion_states(term: DynamicTerm, t, q, *, dt: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Joint rates and accelerations ``(n, 2)`` of angles ``q`` ``(n, 2)`` at times ``t``, as ``sail estimate`` derives them.

    Zero-phase, with the period ``dt`` given or probed from the first
    steps (:class:`sailforce.motion.differentiate.RateTracker`); NaN where the
    motion is unknown (start, end, gaps, invalid samples): nothing raises.
    """
    tracker = RateTracker(term.differentiator, dt)
    parts = [tracker.feed(t, q), tracker.finish()]
    return np.concatenate([parts[0][0], parts[1][0]]), np.concatenate([parts[0][1], parts[1][1]])


def estimate_moving(cal, term: DynamicTerm, t, theta1, theta2, load1, load2, *, rates=None, dt: float | None = None):
    """Offline force estimate with the dynamic term: ``(fx, fy, status, inertial)``.

    ``rates`` ``(omega, alpha)``, each ``(n, 2)`` [rad/s, rad/s^2], are
    used when measured; otherwise they are derived from ``t`` and the
    angles, block by block (:class:`~sailforce.motion.differentiate.RatePlan`: the numbers of
    :func:`motion_states`).  ``inertial`` ``(n, 2)`` is the
    subtracted dynamic load in reading units; samples whose motion is
    unknown (start, end, around gaps) get NaN there and the status
    :data:`sailforce.estimate.estimator.MOTION_UNKNOWN` unless a static status
    outranks it.
    """
    q = np.column_stack([np.asarray(theta1, dtype=float), np.asarray(theta2, dtype=float)])  # one copy
    shear_model = term.shear_model(cal.arm)
    if rates is not None:
        qd, qdd = rates
        return estimate_with_rates(cal, shear_model, q[:, 0], q[:, 1], load1, load2, qd[:, 0], qd[:, 1], qdd[:, 0], qdd[:, 1])
    plan = RatePlan.of(t, q, term.differentiator, dt)  # the rates of each block computed where it is estimated

    def motion(start: int, stop: int):
        rate, accel = plan.block(start, stop)
        return rate[:, 0], rate[:, 1], accel[:, 0], accel[:, 1]

    return estimate_moving_blocks(cal, shear_model, q[:, 0], q[:, 1], load1, load2, motion)
