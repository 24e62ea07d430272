"""Sweeps over poses and force directions: grids, and the rows a sweep produces.

Degrees live here only in :func:`parse_spec`, which reads CLI text; every
other function takes radians.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from .errors import SpecError
from .fem.response import ArmResponse, member_stresses
from .statics import SINGULAR_SIN_DELTA, singular_pose_error, singular_poses

#: Slack, in steps, when deciding whether ``stop`` is reached in
#: ``start:stop:step``: 1e-9 of a step absorbs decimal rounding such as
#: 0.1 * 3 != 0.3 and nothing a user could mean.
SPEC_STEP_SLACK = 1e-9

#: A sweep larger than this many samples is refused rather than exhausting memory.
MAX_SPEC_SAMPLES = 10_000_000

COLUMNS = ("theta1_deg", "theta2_deg", "phi_deg", "fx_N", "fy_N", "load1", "load2", "t1_Nm", "t2_Nm")



def parse_spec(text: str, name: str = "value") -> np.ndarray:
    """Read ``A`` or ``start:stop:step`` (stop inclusive) into a 1-D array.

    >>> parse_spec("0:345:15", "phi").size
    24
    >>> parse_spec("-7.5:97.5:15", "theta2").tolist()
    [-7.5, 7.5, 22.5, 37.5, 52.5, 67.5, 82.5, 97.5]
    >>> parse_spec("120").tolist()
    [120.0]
    >>> parse_spec("0:0:0").tolist()
    [0.0]
    """
    parts = text.split(":")
    try:
        numbers = [float(p) for p in parts]
    except ValueError:
        raise SpecError(f"{name}: expected a number or start:stop:step, got {text!r}") from None
    if not all(math.isfinite(v) for v in numbers):
        raise SpecError(f"{name}: values must be finite, got {text!r}")
    if len(numbers) == 1:
        return np.array(numbers)
    if len(numbers) != 3:
        raise SpecError(f"{name}: expected start:stop:step with three numbers, got {text!r}")
    start, stop, step = numbers
    if start == stop:  # a single value written as a range, whatever the step
        return np.array([start])
    if step == 0 or (stop - start) * step < 0:
        raise SpecError(f"{name}: step {step:g} never goes from {start:g} to {stop:g}")
    count = math.floor((stop - start) / step + SPEC_STEP_SLACK) + 1
    if count > MAX_SPEC_SAMPLES:
        raise SpecError(f"{name}: {text!r} has {count} samples, more than {MAX_SPEC_SAMPLES}")
    return start + step * np.arange(count)


def pose_grid(theta1, theta2) -> tuple[np.ndarray, np.ndarray]:
    """Every (theta1, theta2) pair, theta1 varying slowest, flattened [rad]."""
    t1, t2 = np.meshgrid(np.asarray(theta1, float), np.asarray(theta2, float), indexing="ij")
    return t1.ravel(), t2.ravel()


def check_not_singular(theta1, theta2, min_sin_delta: float = SINGULAR_SIN_DELTA) -> None:
    """Refuse collapsed poses, where the linkage is (nearly) a mechanism."""
    bad = singular_poses(theta1, theta2, min_sin_delta)
    if np.any(bad):
        raise singular_pose_error(theta1, theta2, bad, min_sin_delta, hint="")


def sweep_rows(response: ArmResponse, phi, force: float, transduction: str) -> dict[str, np.ndarray]:
    """The rows of a sweep: every pose of ``response`` (flat) times every force angle ``phi`` [rad].

    Each force follows from the unit-load responses by superposition.
    Returns the :data:`COLUMNS` (angles in degrees) plus ``cell_shear1/2``
    [N] and ``safety_factor`` (the smallest over the members), one entry per
    row, pose-major.
    """
    phi = np.asarray(phi, dtype=float)
    n_pose, n_phi = response.theta1.size, phi.size
    fx = force * np.cos(phi)
    fy = force * np.sin(phi)
    force_vectors = np.stack([fx, fy])  # (2, n_phi)
    signal = response.signal(transduction).reshape(n_pose, 2, 2) @ force_vectors  # (n_pose, 2, n_phi)
    torque = response.torques.reshape(n_pose, 2, 2) @ force_vectors
    shear = response.cell_forces.reshape(n_pose, 2, 3, 2)[:, :, 1] @ force_vectors
    stresses = member_stresses(_flat(response), fx[None, :], fy[None, :])  # (n_pose, n_phi, E, 2)
    rows = {
        "theta1_deg": np.repeat(np.degrees(response.theta1.ravel()), n_phi),
        "theta2_deg": np.repeat(np.degrees(response.theta2.ravel()), n_phi),
        "phi_deg": np.tile(np.degrees(phi), n_pose),
        "fx_N": np.tile(fx, n_pose),
        "fy_N": np.tile(fy, n_pose),
        "load1": signal[:, 0].ravel(),
        "load2": signal[:, 1].ravel(),
        "t1_Nm": torque[:, 0].ravel(),
        "t2_Nm": torque[:, 1].ravel(),
        "cell_shear1": shear[:, 0].ravel(),
        "cell_shear2": shear[:, 1].ravel(),
        "safety_factor": stresses.safety_factor.min(axis=-1).ravel(),
    }
    return rows


def _flat(response: ArmResponse) -> ArmResponse:
    """The response with its batch flattened to (N, 1) so forces broadcast along a new phi axis."""
    n = response.theta1.size
    return replace(response, end_forces=response.end_forces.reshape((n, 1) + response.end_forces.shape[-3:]))
