"""A six-axis force/torque sensor at the handle: its frame, its clock, its recording, and a simulated one.

A lab that borrows an F/T sensor (ATI, Bota) mounts it under the handle and
records it on its own computer or DAQ: ``t_s, fx, fy, fz, tx, ty, tz`` in
the sensor's frame, at its own rate, on its own clock.  Three things
separate that recording from the hand force SAIL needs, in the robot's base
frame at the robot's ticks:

- **the clock**: the sensor's time reads ``t_robot + clock_offset_s``;
- **the frame**: the sensor's x axis points at ``phi`` from the base's
  x axis, ``phi = mount + theta1`` when it is fixed to the link that carries
  the handle (link l3, parallel to l1, turns with theta1: docs/index.md,
  "The linkage"), ``phi = mount`` when it is fixed to the base;
  ``F_sensor = R(-phi) F_base``;
- **its offsets**: ``b``, what it reads with no force (its zero, and the
  handle's weight in a tilted plane).

So ``F_base = R(phi) (F_sensor - b)``.  :mod:`sailforce.reference.align`
finds the clock offset, :mod:`sailforce.reference.frame` the mount and the
offsets.  Only the in-plane forces matter to SAIL; fz and the torques are
read, checked, and kept out of the way.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError, TableError
from ..io.tables import read_clean

#: The columns of a reference sensor's recording: its time [s] on its own clock, forces [N], torques [N m].
REFERENCE_SENSOR_COLUMNS = ("t_s", "fx", "fy", "fz", "tx", "ty", "tz")

#: Where the sensor sits: on the handle's link (its frame turns with theta1), or on the base.
MOUNTS = ("link", "base")

#: The simulated sensor's fz reads the handle's weight [N] (a 0.5 kg handle), and its tx, ty the in-plane force
#: this far below the grip [m]; its torques' noise is the force noise times :data:`SIMULATED_TORQUE_NOISE_M` [m].
SIMULATED_HANDLE_WEIGHT_N = 5.0
SIMULATED_GRIP_HEIGHT_M = 0.04
SIMULATED_TORQUE_NOISE_M = 0.02


@dataclass(frozen=True)
class ReferenceSensor:
    """A reference F/T sensor as :func:`simulate_reference` draws it (defaults: a Bota-like sensor at 500 Hz)."""

    rate_Hz: float = 500.0  #: its sampling rate, on its own clock
    noise_N: float = 0.05  #: each force axis's noise, rms [N] (ATI Mini45: 1/16 N resolution)
    mount_rad: float = np.radians(25.0)  #: its x axis from the link's (or the base's) x axis [rad]
    clock_offset_s: float = 0.25  #: its clock less the robot's [s]
    offsets_N: tuple[float, float] = (0.8, -0.5)  #: what it reads in-plane with no force [N]
    on: str = "link"  #: one of :data:`MOUNTS`

    def __post_init__(self) -> None:
        if self.on not in MOUNTS:
            raise InputError(f"a reference sensor sits on the {' or the '.join(MOUNTS)}, not {self.on!r}")
        if not (np.isfinite(self.rate_Hz) and self.rate_Hz > 0):
            raise InputError(f"a reference sensor's rate must be a positive number of Hz, not {self.rate_Hz!r}")
        if not (np.isfinite(self.noise_N) and self.noise_N >= 0):
            raise InputError(f"a reference sensor's noise must be zero or more newtons, not {self.noise_N!r}")


def sensor_angle(mount_rad: float, theta1, on: str = "link") -> np.ndarray:
    """The sensor frame's angle ``phi`` in the base frame [rad]: ``mount + theta1`` on the link, ``mount`` on the base."""
    theta1 = np.asarray(theta1, float)
    return mount_rad + theta1 if on == "link" else np.full(theta1.shape, float(mount_rad))


def rotate(phi, f: np.ndarray) -> np.ndarray:
    """``R(phi) f`` for ``f`` of shape ``(..., 2)``: a vector's base-frame components from its components in a frame
    at ``phi``."""
    c, s = np.cos(phi), np.sin(phi)
    return np.stack([c * f[..., 0] - s * f[..., 1], s * f[..., 0] + c * f[..., 1]], axis=-1)


def rotation(phi) -> np.ndarray:
    """``R(phi)`` of shape ``(..., 2, 2)``."""
    c, s = np.cos(phi), np.sin(phi)
    return np.stack([np.stack([c, -s], axis=-1), np.stack([s, c], axis=-1)], axis=-2)


def to_base(f_sensor: np.ndarray, phi, offsets_N) -> np.ndarray:
    """``F_base = R(phi) (F_sensor - b)`` (module docstring)."""
    return rotate(phi, np.asarray(f_sensor, float) - np.asarray(offsets_N, float))


@dataclass(frozen=True)
class ReferenceRecording:
    """A reference sensor's in-plane recording."""

    t: np.ndarray  #: ``(n,)`` its time [s], on its own clock, strictly increasing
    force: np.ndarray  #: ``(n, 2)`` fx, fy in its own frame [N]
    source: str = ""  #: the file it came from

    @property
    def rate_Hz(self) -> float:
        """Its median sampling rate."""
        return float(1.0 / np.median(np.diff(self.t)))


def read_reference(path: str | Path) -> ReferenceRecording:
    """A reference sensor's recording (:data:`REFERENCE_SENSOR_COLUMNS`; fz and the torques may be absent).

    Every row must be clean (:func:`sailforce.io.tables.read_clean`) and the time strictly increasing.
    """
    values = read_clean(path, ("t_s", "fx", "fy"), "The reference sensor's recording")
    t = values["t_s"]
    if t.size < 2:
        raise TableError(f"{path}: the reference sensor's recording has {t.size} row(s); it needs a recording")
    steps = np.diff(t)
    if not np.all(steps > 0):
        row = int(np.argmax(steps <= 0)) + 2
        raise TableError(f"{path}: t_s does not increase at data row {row} ({t[row - 2]:.6g} then {t[row - 1]:.6g} s): "
                         "a reference recording's time must increase strictly")  # fmt: skip
    return ReferenceRecording(t, np.column_stack([values["fx"], values["fy"]]), str(path))


def simulate_reference(t_robot, theta1, force, sensor: ReferenceSensor = ReferenceSensor(), *,
                       seed: int = 0) -> dict[str, np.ndarray]:  # fmt: skip
    """What ``sensor`` records of the hand's ``force`` ``(n, 2)`` [N, base frame] along a recording at ``t_robot``.

    The sensor samples at its own rate over the recording's span on its own
    clock; the force and ``theta1`` [rad] are interpolated linearly to its
    instants.  fz reads the handle's weight and the torques the in-plane
    force below the grip (:data:`SIMULATED_HANDLE_WEIGHT_N`,
    :data:`SIMULATED_GRIP_HEIGHT_M`), each with the sensor's noise.  Returns
    the columns of :data:`REFERENCE_SENSOR_COLUMNS`.
    """
    t_robot = np.asarray(t_robot, float)
    rng = np.random.default_rng(seed)
    start = t_robot[0] + sensor.clock_offset_s
    own = start + np.arange(int(np.floor((t_robot[-1] - t_robot[0]) * sensor.rate_Hz)) + 1) / sensor.rate_Hz
    at = own - sensor.clock_offset_s
    f = np.column_stack([np.interp(at, t_robot, force[:, k]) for k in range(2)])
    phi = sensor_angle(sensor.mount_rad, np.interp(at, t_robot, np.asarray(theta1, float)), sensor.on)
    f_sensor = rotate(-phi, f) + np.asarray(sensor.offsets_N, float)
    noise = rng.normal(0.0, sensor.noise_N, (own.size, 6))
    f_sensor = f_sensor + noise[:, :2]
    h, e = SIMULATED_GRIP_HEIGHT_M, SIMULATED_TORQUE_NOISE_M
    return {"t_s": own, "fx": f_sensor[:, 0], "fy": f_sensor[:, 1], "fz": -SIMULATED_HANDLE_WEIGHT_N + noise[:, 2],
            "tx": -h * f_sensor[:, 1] + e * noise[:, 3], "ty": h * f_sensor[:, 0] + e * noise[:, 4], "tz": e * noise[:, 5]}
