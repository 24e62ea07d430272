"""The calibration models, linearised about the robot file: what each hold tells the fit, and what an error costs.

A hold (pose theta, known force F) gives each cell a reading
``r = o + M(theta; phi) F`` [counts], with ``phi`` the model's free parameters.
Near the robot file's values a small error ``dphi`` moves the readings by
``A(theta, F) dphi``, where ``A = dr/dphi`` (2 x p) is the hold's regressor, and
moves the force the estimator returns by ``dF = -M^-1 A dphi`` (the estimator
solves ``M F = r - o``, seed Eq. 8).  Everything the planner predicts is a
product of these two matrices (:mod:`sailforce.plan.design`).

- **physics** (:mod:`sailforce.fit.physics`): each cell's offset and gain, and
  the free robot-file keys, ``r_i = o_i + g_i (S0(delta; k) R(-theta2) F)_i``
  (the frame turns rigidly with the arm: docs/errata.md, Physics).  The keys'
  columns are central differences of the frame model in the coordinates the
  fit uses (log for a stiffness: :class:`sailforce.fit.identify.Parameter`),
  so that the model is linear in them near the file's values.
- **matrix** (:mod:`sailforce.fit.matrix`): ``r_i = o_i + sum_k T_k(x(delta))
  (C_k J^T F)_i``, linear in the offsets and the Chebyshev coefficients, so
  its regressor is exact.

The sensing matrix ``M`` of both is the robot file's frame map, in counts per
newton (:data:`sailforce.synthetic.HX711_COUNTS_PER_MV_V` per mV/V): the
prior that the plan is made for.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..fit.identify import parameter, sensing_map, with_free_springs, with_parameter
from ..fit.physics import DEFAULT_FREE, DEFAULT_TRANSDUCTION
from ..io.robotkeys import get_key
from ..robot import Robot
from ..sensing.maps import _chebyshev_argument, rotation, torque_rows
from ..synthetic import HX711_COUNTS_PER_MV_V

#: The models the planner knows.
MODELS = ("physics", "matrix")
#: The matrix model's Chebyshev order unless told (the seed study's compensators pick 4-6 on many deltas; a
#: plan of a few dozen holds supports a low one).
DEFAULT_MATRIX_ORDER = 3
#: Central-difference step of a free key's column, in the fit's coordinate (log for a stiffness: 1e-4 relative).
DIFFERENCE_STEP = 1e-4


@dataclass(frozen=True)
class Linearised:
    """One calibration model about the robot file: its parameters' names and its regressor (module docstring)."""

    robot: Robot
    model: str
    names: tuple[str, ...]  #: the parameters, offsets first
    free: tuple[str, ...]  #: physics: the free robot-file keys
    order: int  #: matrix: the Chebyshev order
    delta_range: tuple[float, float]  #: matrix: the Chebyshev argument's range [rad] (the calibrated deltas)

    @property
    def size(self) -> int:
        return len(self.names)

    def sensing(self, theta1, theta2) -> np.ndarray:
        """M, ``(n, 2, 2)`` [counts/N]: the robot file's readings per unit force at each pose [rad]."""
        theta1, theta2 = np.atleast_1d(np.asarray(theta1, float)), np.atleast_1d(np.asarray(theta2, float))
        return self._map(self.robot, theta1 - theta2) @ rotation(-theta2)

    def regressor(self, theta1, theta2, fx, fy) -> np.ndarray:
        """A = dr/dphi, ``(n, 2, p)`` [counts per unit parameter], at holds: poses [rad] and forces [N]."""
        theta1, theta2, fx, fy = (np.atleast_1d(np.asarray(a, float)) for a in np.broadcast_arrays(theta1, theta2, fx, fy))
        n = theta1.size
        force = np.stack([fx, fy], axis=-1)
        columns = [np.broadcast_to(np.eye(2)[:, i], (n, 2)) for i in range(2)]  # the offsets
        if self.model == "physics":
            turned = (rotation(-theta2) @ force[..., None])[..., 0]  # F in the arm's frame at theta2 = 0
            base = (self._map(self.robot, theta1 - theta2) @ turned[..., None])[..., 0]  # (n, 2) counts
            columns += [base * np.eye(2)[i] for i in range(2)]  # relative gains: dr_i / d(log g_i)
            for key in self.free:
                p = parameter(self.robot, key)
                x = p.to_x(float(get_key(self.robot, key)))
                up, down = (with_parameter(self.robot, key, p.from_x(x + s * DIFFERENCE_STEP)) for s in (1.0, -1.0))
                delta = theta1 - theta2
                diff = (self._map(up, delta) - self._map(down, delta)) / (2.0 * DIFFERENCE_STEP)
                columns.append((diff @ turned[..., None])[..., 0])
        else:
            torque = (torque_rows(self.robot.arm, theta1, theta2) @ force[..., None])[..., 0]  # J^T F (Eq. 7)
            basis = np.polynomial.chebyshev.chebvander(_chebyshev_argument(theta1 - theta2, self.delta_range), self.order)
            for k in range(self.order + 1):
                for i in range(2):
                    for a in range(2):
                        columns.append(np.eye(2)[i] * (basis[:, k] * torque[:, a])[:, None])
        return np.stack(columns, axis=-1)

    def _map(self, robot: Robot, delta: np.ndarray) -> np.ndarray:
        """S0(delta) [counts/N] at theta2 = 0, one frame solve for the distinct deltas."""
        unique, index = np.unique(delta, return_inverse=True)
        return HX711_COUNTS_PER_MV_V * sensing_map(robot, unique, DEFAULT_TRANSDUCTION)[index]


def linearise(robot: Robot, model: str, *, free: Sequence[str] | None = None, order: int | None = None,
              delta_range: tuple[float, float] = (np.radians(30.0), np.radians(120.0))) -> Linearised:  # fmt: skip
    """The calibration ``model`` ("physics" or "matrix") linearised about ``robot`` (module docstring).

    ``free``: the physics model's free keys (default its own,
    :data:`sailforce.fit.physics.DEFAULT_FREE`); ``order``: the matrix model's
    (:data:`DEFAULT_MATRIX_ORDER`); ``delta_range`` [rad]: the deltas the plan
    may use (the matrix series is defined over it).
    """
    if model not in MODELS:
        raise InputError(f"unknown calibration model {model!r}: expected one of {', '.join(MODELS)}")
    if model == "physics":
        keys = tuple(DEFAULT_FREE if free is None else free)
        if not keys:
            raise InputError("the physics model needs at least one free key besides the offsets and gains (--free)")
        start = with_free_springs(robot, keys)
        for key in keys:
            parameter(start, key)  # an unknown or static-inert key is refused by name here
        names = ("offset1", "offset2", "gain1", "gain2", *keys)
        return Linearised(start, model, names, keys, 0, delta_range)
    if free:
        raise InputError("--free is for the physics model: the matrix model's parameters are its series' coefficients")
    k = DEFAULT_MATRIX_ORDER if order is None else int(order)
    if k < 0:
        raise InputError(f"the matrix model's order must be 0 or more, got {k}")
    names = ("offset1", "offset2", *(f"c[{j}][{i}][{a}]" for j in range(k + 1) for i in range(2) for a in range(2)))
    return Linearised(robot, model, names, (), k, delta_range)
