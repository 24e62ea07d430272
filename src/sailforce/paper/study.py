"""The seed paper's virtual study (Section 3), run on the frame model: no plotting here.

:func:`run_study` follows the protocol exactly as docs/errata.md lists it:

1. stress patterns: 10 N at phi = 0..315 deg in 45 deg steps, at
   :attr:`Protocol.stress_pose_deg` (the seed does not say which pose);
2. sweep 1 (load cell 1): theta2 = 0, theta1 = 15..120 deg; sweep 2 (load
   cell 2): theta1 = 120, theta2 = 0..105 deg; phi = 0..345 deg, all in 15
   deg steps: 192 runs each;
3. Table 4: amplitude and phase of each load-cell curve against the torque
   predicted by Eq. 7, from least-squares sinusoid fits
   (:mod:`sailforce.sensing.maps` states the sign convention);
4. polynomial regressors of each Table 4 column (:mod:`sailforce.sensing.polynomial`);
5. validation on the offset grids: theta2 = 0, theta1 = 22.5..127.5; then
   theta1 = 120, theta2 = -7.5..97.5; RMSE before and after compensation.

and then goes beyond the seed: a :class:`MatrixCompensator` fitted
on all sweep data of both cells, and the force-vector error of every model
over the whole workspace delta = 15..165 deg.

Degrees appear only in :class:`Protocol` (the protocol is stated in degrees)
and in the Table 4 columns, which are the seed's.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from enum import StrEnum
from functools import cache

import numpy as np

from ..errors import InputError
from ..estimate.estimator import estimate_force
from ..fem.model import ArmModel, build_model, build_models
from ..fem.response import ArmResponse, simulate_model, simulate_models
from ..fit.matrix import fit_matrix_compensator
from ..robot import Robot
from ..sensing.maps import (
    AmplitudePhaseCompensator,
    MatrixCompensator,
    SensingModel,
    TorqueScale,
    amplitude_phase,
    sinusoid_rows,
    torque_rows,
)
from ..sensing.polynomial import DEFAULT_CRITERION, DEFAULT_THRESHOLD, PolynomialFit, select_order

TABLE4_COLUMNS = ("delta_deg", "amplitude_1", "phase_1_deg", "amplitude_2", "phase_2_deg")
#: How ``table4.csv`` writes its numbers: ten significant digits, beyond any fit's precision.
TABLE4_FORMAT = "%.10g"
#: :func:`table4` (rows from the unit solution) and the study's sinusoid fits agree to this (relative).
TABLE4_AGREEMENT = 1e-12


class ModelId(StrEnum):
    """Short ids of the study's sensing models: keys of ``force_rmse`` and of the workspace errors.

    Display labels live with the report (:data:`sailforce.report.labels.MODEL_COLOURS` and the report tables).
    """

    UNCOMPENSATED = "uncompensated"  #: one least-squares gain per cell, T_i = k_i s_i
    SEED = "seed"  #: the seed's gain and phase per cell, A_i(delta), P_i(delta)
    MATRIX = "matrix"  #: the 2x2 sensing map C(delta), fitted on both sweeps
    MATRIX_WIDE = "matrix-wide"  #: the same, fitted on a sweep spanning the workspace


def _steps(start: float, stop: float, step: float) -> tuple[float, ...]:
    return tuple(float(v) for v in np.arange(start, stop + step / 2, step))


@dataclass(frozen=True)
class Protocol:
    """The seed's study protocol (Section 3; docs/errata.md, The study protocol), in degrees."""

    force_N: float = 10.0
    phi_deg: tuple[float, ...] = _steps(0.0, 345.0, 15.0)
    stress_phi_deg: tuple[float, ...] = _steps(0.0, 315.0, 45.0)
    stress_pose_deg: tuple[float, float] = (75.0, 0.0)  #: our choice: a sweep-1 pose at delta = 75 deg
    sweep1_theta1_deg: tuple[float, ...] = _steps(15.0, 120.0, 15.0)
    sweep1_theta2_deg: float = 0.0
    sweep2_theta1_deg: float = 120.0
    sweep2_theta2_deg: tuple[float, ...] = _steps(0.0, 105.0, 15.0)
    valid1_theta1_deg: tuple[float, ...] = _steps(22.5, 127.5, 15.0)
    valid1_theta2_deg: float = 0.0
    valid2_theta1_deg: float = 120.0
    valid2_theta2_deg: tuple[float, ...] = _steps(-7.5, 97.5, 15.0)
    workspace_delta_deg: tuple[float, ...] = _steps(15.0, 165.0, 2.5)
    #: a calibration sweep spanning the workspace, for the "calibrate what you use" comparison
    wide_calibration_delta_deg: tuple[float, ...] = _steps(15.0, 165.0, 15.0)

    def with_table4_deltas(self, delta_deg) -> Protocol:
        """This protocol with its calibration sweeps at the deltas [deg] of a Table 4 (rising, in (0, sweep 2's theta1]).

        Sweep 1 turns theta1 = delta at its fixed theta2; sweep 2 holds its theta1 and turns
        theta2 = theta1 - delta, so that both give the table's deltas in order.
        """
        delta = np.asarray(delta_deg, dtype=float)
        top = self.sweep2_theta1_deg - self.sweep1_theta2_deg
        if delta.size < 3 or not (np.all(np.diff(delta) > 0) and delta[0] > 0 and delta[-1] <= top):
            raise InputError(f"delta_deg must rise through at least 3 values in (0, {top:g}] deg: sweep 2 holds "
                             f"theta1 = {self.sweep2_theta1_deg:g} deg and turns theta2 = {self.sweep2_theta1_deg:g} - delta")  # fmt: skip
        return replace(self, sweep1_theta1_deg=tuple(map(float, delta + self.sweep1_theta2_deg)),
                       sweep2_theta2_deg=tuple(map(float, self.sweep2_theta1_deg - delta[::-1])))  # fmt: skip

    def grid_deg(self, cell: int, *, validation: bool = False) -> tuple:
        """(theta1, theta2) [deg] of sweep ``cell`` (1 or 2), or of its validation grid: one swept, one fixed."""
        if cell not in (1, 2):
            raise InputError(f"cell must be 1 or 2, not {cell!r}")
        if validation:
            return ((self.valid1_theta1_deg, self.valid1_theta2_deg) if cell == 1
                    else (self.valid2_theta1_deg, self.valid2_theta2_deg))  # fmt: skip
        return ((self.sweep1_theta1_deg, self.sweep1_theta2_deg) if cell == 1
                else (self.sweep2_theta1_deg, self.sweep2_theta2_deg))  # fmt: skip

    def sweep_poses(self, cell: int) -> tuple[np.ndarray, np.ndarray]:
        """(theta1, theta2) [rad] of sweep ``cell`` (1 or 2)."""
        return _poses(*self.grid_deg(cell))

    def validation_poses(self, cell: int) -> tuple[np.ndarray, np.ndarray]:
        """(theta1, theta2) [rad] of the validation grid for load cell ``cell``."""
        return _poses(*self.grid_deg(cell, validation=True))

    def runs(self) -> tuple[int, int]:
        """FE runs of both sweeps together and of both validation grids together (the seed's: 384 + 384)."""
        per_pose = len(self.phi_deg)
        sweeps = sum(self.sweep_poses(cell)[0].size for cell in (1, 2))
        validation = sum(self.validation_poses(cell)[0].size for cell in (1, 2))
        return sweeps * per_pose, validation * per_pose

    def describe_grid(self, cell: int, *, validation: bool = False) -> str:
        """A grid in words, e.g. ``"θ2 = 0°, θ1 = 22.5…127.5°"``: the fixed angle, then the swept one's span."""
        theta1, theta2 = self.grid_deg(cell, validation=validation)
        if isinstance(theta1, tuple):
            return f"θ2 = {theta2:g}°, θ1 = {span_deg(theta1)}"
        return f"θ1 = {theta1:g}°, θ2 = {span_deg(theta2)}"


def span_deg(values_deg, *, step: bool = False) -> str:
    """``"22.5…127.5°"``: the first and last of a grid in degrees (or its one value); ``step`` adds its step."""
    values = np.atleast_1d(np.asarray(values_deg, dtype=float))
    if values.size == 1:
        return f"{values[0]:g}°"
    text = f"{values[0]:g}…{values[-1]:g}°"
    return f"{text} in {values[1] - values[0]:g}° steps" if step else text


def _poses(theta1_deg, theta2_deg) -> tuple[np.ndarray, np.ndarray]:
    t1, t2 = np.broadcast_arrays(np.radians(np.atleast_1d(theta1_deg)), np.radians(np.atleast_1d(theta2_deg)))
    return t1.astype(float), t2.astype(float)


@dataclass(frozen=True)
class Curves:
    """Load-cell signals and predicted torques over phi at a set of poses.

    ``signal`` and ``torque`` have shape ``(n_poses, 2, n_phi)`` (both cells);
    ``unit_signal`` is ``(n_poses, 2, 2)``, the signal per unit (Fx, Fy).
    """

    theta1: np.ndarray
    theta2: np.ndarray
    signal: np.ndarray
    torque: np.ndarray
    unit_signal: np.ndarray

    @property
    def delta(self) -> np.ndarray:
        return self.theta1 - self.theta2


@dataclass(frozen=True)
class Rmse:
    """Per-torque RMSE on the validation grids: T1 on grid 1, T2 on grid 2, and their mean."""

    t1: float
    t2: float

    @property
    def mean(self) -> float:
        return 0.5 * (self.t1 + self.t2)

    def as_dict(self) -> dict[str, float]:
        return {"t1": self.t1, "t2": self.t2, "mean": self.mean}

    def relative(self, amplitude: tuple[float, float]) -> Rmse:
        return Rmse(self.t1 / amplitude[0], self.t2 / amplitude[1])


@dataclass(frozen=True)
class WorkspaceErrors:
    """RMS force-vector error over phi, relative to |F|, at each delta of the workspace grid."""

    delta: np.ndarray  #: [rad]
    relative_error: dict[ModelId, np.ndarray]  #: model -> (n_delta,)


@dataclass(frozen=True, kw_only=True)
class StudyResult:
    """Everything :func:`run_study` computes; :mod:`sailforce.report` draws and writes it."""

    robot: Robot
    transduction: str
    protocol: Protocol
    criterion: str
    threshold: float
    stress_response: ArmResponse
    sweeps: tuple[Curves, Curves]
    prescale: tuple[float, float]  #: k_i [N m per signal unit], least squares over sweep i
    table4: np.ndarray  #: (8, 5), the :data:`TABLE4_COLUMNS`, delta ascending
    regressors: dict[str, PolynomialFit]
    compensator: AmplitudePhaseCompensator
    validation: tuple[Curves, Curves]
    compensated: tuple[np.ndarray, np.ndarray]  #: A_i s_i(phi - P_i) on validation grid i, (n_poses, n_phi)
    rmse_before: Rmse
    rmse_after: Rmse  #: the seed's method: each curve shifted and scaled
    rmse_after_estimator: Rmse  #: T = J^T F-hat, F-hat from both cells through the 2x2 solve
    matrix_compensator: MatrixCompensator
    rmse_matrix: Rmse
    force_rmse: dict[ModelId, float]  #: force-vector RMSE [N] on both validation grids, per model
    workspace: WorkspaceErrors
    #: largest difference between the sweeps' amplitude (relative) and phase [deg] of the
    #: same cell at the same delta: zero in a linear model (docs/errata.md, Physics)
    delta_only_discrepancy: dict[str, float]
    timings: dict[str, float] = field(default_factory=dict, compare=False)

    def rmse_after_per_pose(self, cell: int) -> np.ndarray:
        """RMSE [N m] of the compensated curve of ``cell`` (0 or 1) at each validation pose."""
        error = self.compensated[cell] - self.validation[cell].torque[:, cell]
        return np.sqrt(np.mean(np.square(error), axis=-1))

    @property
    def torque_amplitude(self) -> tuple[float, float]:
        """The predicted torque amplitudes F l3 and F l2 [N m]: the scale of T1 and T2."""
        arm = self.robot.arm
        return self.protocol.force_N * arm.l3, self.protocol.force_N * arm.l2


def run_study(
    robot: Robot,
    transduction: str = "deflection",
    *,
    criterion: str = DEFAULT_CRITERION,
    threshold: float = DEFAULT_THRESHOLD,
    protocol: Protocol = Protocol(),
) -> StudyResult:
    """Run the seed's whole virtual study on ``robot``; see the module docstring."""
    model = build_model(robot)
    phi = np.radians(protocol.phi_deg)
    force = protocol.force_N
    arm = robot.arm

    def curves(theta1, theta2) -> Curves:
        return _curves(model, transduction, theta1, theta2, phi, force)

    stress_response = simulate_model(model, *np.radians(protocol.stress_pose_deg))
    sweeps = (curves(*protocol.sweep_poses(1)), curves(*protocol.sweep_poses(2)))
    prescale = tuple(_least_squares_scale(sweeps[i].signal[:, i], sweeps[i].torque[:, i]) for i in range(2))

    table4 = _table4(sweeps, phi, force, arm)
    delta_deg = table4[:, 0]
    regressors = {
        name: select_order(delta_deg, table4[:, k], criterion=criterion, threshold=threshold)
        for k, name in enumerate(TABLE4_COLUMNS[1:], start=1)
    }
    compensator = AmplitudePhaseCompensator(
        arm,
        (regressors["amplitude_1"], regressors["amplitude_2"]),
        (regressors["phase_1_deg"], regressors["phase_2_deg"]),
        (float(np.radians(delta_deg.min())), float(np.radians(delta_deg.max()))),
    )

    validation = (curves(*protocol.validation_poses(1)), curves(*protocol.validation_poses(2)))
    compensated = tuple(_shifted_curve(validation[i], i, compensator, phi, force) for i in range(2))
    rmse_before = Rmse(*(_rms(prescale[i] * validation[i].signal[:, i] - validation[i].torque[:, i]) for i in range(2)))
    rmse_after = Rmse(*(_rms(compensated[i] - validation[i].torque[:, i]) for i in range(2)))

    samples = _samples(sweeps, phi, force)
    matrix = fit_matrix_compensator(arm, *samples)
    models: dict[ModelId, SensingModel] = {
        ModelId.UNCOMPENSATED: TorqueScale(arm, prescale), ModelId.SEED: compensator, ModelId.MATRIX: matrix}
    rmse_after_estimator = _estimator_rmse(compensator, validation, arm)
    rmse_matrix = _estimator_rmse(matrix, validation, arm)
    force_rmse = {name: _force_rmse(m, validation, phi, force) for name, m in models.items()}

    wide = curves(*_poses(protocol.wide_calibration_delta_deg, 0.0))
    models[ModelId.MATRIX_WIDE] = fit_matrix_compensator(arm, *_samples((wide,), phi, force))
    workspace_delta = np.radians(protocol.workspace_delta_deg)
    grid = curves(workspace_delta, np.zeros_like(workspace_delta))
    workspace = WorkspaceErrors(
        workspace_delta, {name: _relative_force_error(m, grid, phi, force) for name, m in models.items()}
    )
    return StudyResult(
        robot=robot, transduction=transduction, protocol=protocol, criterion=criterion, threshold=threshold,
        stress_response=stress_response, sweeps=sweeps, prescale=prescale, table4=table4, regressors=regressors,
        compensator=compensator, validation=validation, compensated=compensated, rmse_before=rmse_before,
        rmse_after=rmse_after, rmse_after_estimator=rmse_after_estimator, matrix_compensator=matrix,
        rmse_matrix=rmse_matrix, force_rmse=force_rmse, workspace=workspace,
        delta_only_discrepancy=_delta_only_discrepancy(sweeps, phi, force, arm),
    )


def _curves(model: ArmModel, transduction: str, theta1, theta2, phi: np.ndarray, force: float) -> Curves:
    """Both cells' signals and the predicted torques at each pose, for ``force`` at each angle ``phi``."""
    unit = simulate_model(model, theta1, theta2).signal(transduction)
    directions = np.stack([np.cos(phi), np.sin(phi)]) * force  # (2, n_phi)
    return Curves(theta1, theta2, unit @ directions, torque_rows(model.robot.arm, theta1, theta2) @ directions, unit)


def table4(robot: Robot, transduction: str = "deflection", *, protocol: Protocol = Protocol()) -> np.ndarray:
    """Seed Table 4 of ``robot``: (n_delta, 5) :data:`TABLE4_COLUMNS` from the two sweeps alone (no validation).

    The quantity :mod:`sailforce.fit.identify` fits a robot's physical parameters to, so it is lean: both
    sweeps in one frame solve, and the sensing rows taken from the unit-load solution.  The study's
    least-squares sinusoid fit (:func:`~sailforce.sensing.maps.sinusoid_rows`) of the noise-free curves
    F (r_x cos phi + r_y sin phi) returns those rows exactly (to rounding), so the two agree to
    :data:`TABLE4_AGREEMENT` (``tests/test_study.py``).
    """
    theta1, theta2, order, split = _table4_plan(protocol)
    unit = simulate_model(build_model(robot), theta1, theta2).signal(transduction)  # (n1 + n2, 2 cells, 2)
    return _table4_rows(robot.arm, theta1, theta2, order, split, unit)


def table4_many(robots, transduction: str = "deflection", *, protocol: Protocol = Protocol()) -> list[np.ndarray]:
    """:func:`table4` of each of ``robots``, their frames solved together (:func:`~sailforce.fem.response.simulate_models`)."""
    theta1, theta2, order, split = _table4_plan(protocol)
    responses = simulate_models(build_models(robots), theta1, theta2)
    return [_table4_rows(robot.arm, theta1, theta2, order, split, response.signal(transduction))
            for robot, response in zip(robots, responses)]  # fmt: skip


@cache
def _table4_plan(protocol: Protocol) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Both sweeps' poses end to end, each sweep's ascending-delta order (into them), sweep 1's size; once per protocol."""
    (t1a, t2a), (t1b, t2b) = protocol.sweep_poses(1), protocol.sweep_poses(2)
    if not np.allclose(np.sort(t1a - t2a), np.sort(t1b - t2b)):
        raise InputError("the two sweeps must cover the same delta values to share Table 4 rows")
    theta1, theta2 = np.concatenate([t1a, t1b]), np.concatenate([t2a, t2b])
    order = np.concatenate([np.argsort(t1a - t2a), t1a.size + np.argsort(t1b - t2b)])
    for array in (theta1, theta2, order):
        array.flags.writeable = False
    return theta1, theta2, order, t1a.size


def _table4_rows(arm, theta1: np.ndarray, theta2: np.ndarray, order: np.ndarray, split: int, rows: np.ndarray) -> np.ndarray:
    """Table 4 from cell i's reading per unit (Fx, Fy) ``rows`` over sweep i, the sweeps end to end in ``order``."""
    t1, t2 = theta1[order], theta2[order]
    amplitude, phase = amplitude_phase(np.asarray(rows)[order], torque_rows(arm, t1, t2))  # (n1 + n2, 2 cells) each
    first, second = slice(0, split), slice(split, None)
    return np.column_stack([np.degrees((t1 - t2)[first]), amplitude[first, 0], np.degrees(phase[first, 0]),
                            amplitude[second, 1], np.degrees(phase[second, 1])])  # fmt: skip


def table4_from_rows(arm, protocol: Protocol, sweep1_rows: np.ndarray, sweep2_rows: np.ndarray) -> np.ndarray:
    """Seed Table 4 from any model's readings per unit (Fx, Fy) over the protocol's two sweeps.

    ``sweepK_rows`` is ``(n_poses, 2, 2)``: cell i's reading per unit F_j at each pose of sweep K, in the
    protocol's order (the solid model's, :mod:`sailforce.solid.sweep`).  Same columns as :func:`table4`.
    """
    theta1, theta2, order, split = _table4_plan(protocol)
    return _table4_rows(arm, theta1, theta2, order, split, np.concatenate([sweep1_rows, sweep2_rows]))


def _least_squares_scale(signal: np.ndarray, torque: np.ndarray) -> float:
    """The k minimising sum (k s - T)^2: the seed's pre-scaling constant, fitted."""
    return float(np.sum(signal * torque) / np.sum(signal * signal))


def _table4(sweeps: tuple[Curves, Curves], phi, force: float, arm) -> np.ndarray:
    """Amplitude and phase of cell i over sweep i, rows in ascending delta (seed Table 4)."""
    columns = []
    for i, sweep in enumerate(sweeps):
        order = np.argsort(sweep.delta)
        measured = sinusoid_rows(phi, force, sweep.signal[order, i])
        predicted = torque_rows(arm, sweep.theta1[order], sweep.theta2[order])[:, i]
        amplitude, phase = amplitude_phase(measured, predicted)
        columns.append((np.degrees(sweep.delta[order]), amplitude, np.degrees(phase)))
    if not np.allclose(columns[0][0], columns[1][0]):
        raise InputError("the two sweeps must cover the same delta values to share Table 4 rows")
    (delta_deg, a1, p1), (_, a2, p2) = columns
    return np.column_stack([delta_deg, a1, p1, a2, p2])


def _delta_only_discrepancy(sweeps: tuple[Curves, Curves], phi, force: float, arm) -> dict[str, float]:
    """Both cells' amplitude and phase from each sweep, compared at equal delta (sweep 2 runs delta downwards)."""
    per_sweep = []
    for sweep in sweeps:
        order = np.argsort(sweep.delta)
        measured = sinusoid_rows(phi, force, sweep.signal[order])  # (n, 2 cells, 2)
        per_sweep.append(amplitude_phase(measured, torque_rows(arm, sweep.theta1[order], sweep.theta2[order])))
    (a1, p1), (a2, p2) = per_sweep
    return {
        "amplitude_relative": float(np.max(np.abs(a1 - a2) / np.abs(a1))),
        "phase_deg": float(np.degrees(np.max(np.abs(p1 - p2)))),
    }


def _shifted_curve(curves: Curves, i: int, compensator: AmplitudePhaseCompensator, phi, force: float) -> np.ndarray:
    """The seed's compensation of cell i's curve: A_i(delta) s_i(phi - P_i(delta))."""
    amplitude, phase = compensator.parameters(curves.delta)
    shifted = phi[None, :] - phase[:, i, None]  # (n_poses, n_phi)
    row = curves.unit_signal[:, i]  # (n_poses, 2): s_i per unit (Fx, Fy)
    signal = force * (row[:, 0, None] * np.cos(shifted) + row[:, 1, None] * np.sin(shifted))
    return amplitude[:, i, None] * signal


def _rms(error: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(error))))


def _estimates(model: SensingModel, curves: Curves) -> tuple[np.ndarray, np.ndarray]:
    """Force estimated from both cells' signals at every pose and angle, each (n_poses, n_phi)."""
    theta1, theta2 = curves.theta1[:, None], curves.theta2[:, None]
    force = estimate_force(model, theta1, theta2, curves.signal[:, 0], curves.signal[:, 1])
    return force.fx, force.fy


def _estimator_rmse(model: SensingModel, validation, arm) -> Rmse:
    errors = []
    for i, curves in enumerate(validation):
        fx, fy = _estimates(model, curves)
        rows = torque_rows(arm, curves.theta1, curves.theta2)[:, i]  # (n_poses, 2)
        torque = rows[:, 0, None] * fx + rows[:, 1, None] * fy
        errors.append(_rms(torque - curves.torque[:, i]))
    return Rmse(*errors)


def _force_errors(model: SensingModel, curves: Curves, phi, force: float) -> np.ndarray:
    """|F-hat - F| [N] at every pose and angle, (n_poses, n_phi)."""
    fx, fy = _estimates(model, curves)
    return np.hypot(fx - force * np.cos(phi), fy - force * np.sin(phi))


def _force_rmse(model: SensingModel, validation, phi, force: float) -> float:
    return _rms(np.concatenate([_force_errors(model, c, phi, force).ravel() for c in validation]))


def _relative_force_error(model: SensingModel, curves: Curves, phi, force: float) -> np.ndarray:
    return np.sqrt(np.mean(np.square(_force_errors(model, curves, phi, force)), axis=-1)) / force


def _samples(sweeps, phi, force: float) -> tuple[np.ndarray, ...]:
    """Flat (theta1, theta2, fx, fy, load1, load2) samples of every pose and angle of ``sweeps``."""
    parts = []
    for c in sweeps:
        n = c.theta1.size
        parts.append((
            np.repeat(c.theta1, phi.size), np.repeat(c.theta2, phi.size),
            np.tile(force * np.cos(phi), n), np.tile(force * np.sin(phi), n),
            c.signal[:, 0].ravel(), c.signal[:, 1].ravel(),
        ))  # fmt: skip
    return tuple(np.concatenate(column) for column in zip(*parts))
