"""The solid against the frame at one pose: amplitude and phase of every reading, and the torques.

A reading per unit force is a row (a, b) of a ``(2, 2)`` response: under a
force F at angle phi it reads F (a cos phi + b sin phi) = F R cos(phi - P),
with amplitude R = hypot(a, b) and phase P = atan2(b, a).  The comparison
gives, for each cell i, R_solid / R_frame and P_solid - P_frame [deg], of the
torque T_i, the far-face deflection and the relative deflection.
"""

from __future__ import annotations

import math

import numpy as np

from ..fem.response import ArmResponse, simulate
from ..robot import Robot
from ..sensing.maps import torque_rows
from .arm import SolidResponse

#: The readings compared, as SolidResponse fields.
READINGS = ("torques", "deflection", "relative")


def frame_readings(robot: Robot, theta1: float, theta2: float) -> dict[str, np.ndarray]:
    """The frame's torques, far-face and relative deflection per unit (Fx, Fy) at the pose, each ``(2, 2)``."""
    response = simulate(robot, theta1, theta2)
    return {"torques": response.torques, "deflection": response.deflection, "relative": relative_deflection(response)}


def relative_deflection(response: ArmResponse) -> np.ndarray:
    """The frame's far face less near face, along each link's counter-clockwise normal, ``(..., 2, 2)`` [m/N]."""
    dof = response.model.dof
    near = []
    for i, angle in enumerate((response.theta1, response.theta2)):
        u = response.displacements[..., dof[f"C{i + 1}a.u"], :]
        v = response.displacements[..., dof[f"C{i + 1}a.v"], :]
        near.append(-np.sin(angle)[..., None] * u + np.cos(angle)[..., None] * v)
    return response.deflection - np.stack(near, axis=-2)


def amplitude_phase(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Amplitude and phase [rad] of each row (a, b) of ``rows`` (..., 2)."""
    return np.hypot(rows[..., 0], rows[..., 1]), np.arctan2(rows[..., 1], rows[..., 0])


def compare(robot: Robot, solid: SolidResponse) -> dict[str, dict[str, list[float]]]:
    """Per reading: the solid's and the frame's amplitude and phase [deg] for each cell, their ratio and difference."""
    frame = frame_readings(robot, solid.theta1, solid.theta2)
    out = {}
    for name in READINGS:
        (a_s, p_s), (a_f, p_f) = amplitude_phase(getattr(solid, name)), amplitude_phase(frame[name])
        difference = np.degrees(np.angle(np.exp(1j * (p_s - p_f))))
        out[name] = {"solid_amplitude": a_s.tolist(), "frame_amplitude": a_f.tolist(), "ratio": (a_s / a_f).tolist(),
                     "solid_phase_deg": np.degrees(p_s).tolist(), "frame_phase_deg": np.degrees(p_f).tolist(),
                     "phase_difference_deg": difference.tolist()}  # fmt: skip
    return out


def torque_against_jt(robot: Robot, poses, torques) -> float:
    """The largest |T - J^T| of the solid's torques ``(n, 2, 2)`` at ``poses`` ``(n, 2)`` [rad], relative to the largest |J^T|.

    For pin joints the linkage is determinate and the torques per unit force
    are J^T itself (seed Eq. 7): this is the solid's error against statics.
    """
    poses = np.asarray(poses, dtype=float)
    jt = torque_rows(robot.arm, poses[:, 0], poses[:, 1])
    return float(np.max(np.abs(np.asarray(torques) - jt)) / np.max(np.abs(jt)))


def curves(response: np.ndarray, phi: np.ndarray, force: float) -> np.ndarray:
    """``(2, n_phi)``: each row of ``response`` (2, 2) under ``force`` [N] at each angle ``phi`` [rad]."""
    return force * (response[:, :1] * np.cos(phi) + response[:, 1:] * np.sin(phi))


def pose_deg(theta1: float, theta2: float) -> str:
    return f"θ1 = {math.degrees(theta1):g}°, θ2 = {math.degrees(theta2):g}°"
