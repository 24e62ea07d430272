"""The single-axis load cell: its equivalent beam and its transduction.

Each SAIL load cell bridges a gap in a driven link (seed Sec. 3.2: a 40 mm
gap, an MT1041-like 50 kg cell of 7075-T6 aluminium, about 0.5 mm deflection
at capacity).  In the frame model it is one Timoshenko beam element of the
gap's length.

**Equivalent bending stiffness.**  A bending-beam cell is hollowed around its
strain gauges, so the solid block's E I overstates its stiffness by one to two
orders of magnitude.  We calibrate E I so that the datasheet holds: with the
near face clamped and the rated load F_cap applied transversely at the free
far face, the far face moves the rated deflection delta_cap.  Timoshenko
cantilever theory gives delta = F L^3 / (3 E I) + F L / (kappa G A), so

    E I_eq = F_cap L^3 / (3 (delta_cap - F_cap L / (kappa G A)))

with kappa G A from the solid block (its shear term is ~0.4 % of delta_cap for
the defaults).  Axial and shear rigidity come from the block.

**Compliance models** (``compliance``).  What the frame sees of the
cell in bending is its 2x2 cantilever flexibility: with the near face clamped,
a shear V and a moment M at the far face move it by

    (v, r) = C (V, M),   C = [[c_vv, c_vm], [c_vm, c_mm]].

- ``datasheet`` (default): the Timoshenko beam above, E I_eq from the rated deflection;
- ``block``: the solid block's own E I, as SolidWorks models a cell drawn as a
  plain 7075 part (the seed's set-up, Sec. 3.2): 46 times stiffer than the datasheet beam for the defaults;
- ``matrix``: C given outright (``compliance_vv`` [m/N], ``compliance_vm`` [1/N],
  ``compliance_mm`` [1/(N m)]), measured or taken from a solid model.

For a Timoshenko cantilever C = [[L^3/(3EI) + L/(kGA), L^2/(2EI)], [L^2/(2EI), L/EI]].
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .errors import GeometryError
from .materials import AL_7075_T6, Material, RectangularSection

#: How the cell's bending compliance is given (module docstring).
COMPLIANCE_MODELS = ("datasheet", "block", "matrix")

#: What a cell's reading is: its far face's deflection [m] (the seed's surrogate) or its bridge's output [mV/V].
READINGS = ("deflection", "bridge")
#: Default 1-sigma reading noise [mV/V]: 1e-4 of the default 2 mV/V rated output, as the synthetic recordings
#: (sailforce.synthetic.NoiseModel); an HX711 at gain 128 and 10 Hz is quieter (~50 nV on 5 V, 1e-5 mV/V).
DEFAULT_NOISE_MV_V = 2e-4

#: Standard gravity [m/s^2] (CGPM 1901), to turn a capacity in kg into newtons.
STANDARD_GRAVITY = 9.80665


@dataclass(frozen=True)
class LoadCell:
    """An MT1041-like single-axis bending-beam load cell.

    Defaults: 50 kg capacity, 0.5 mm deflection at capacity, 40 mm long,
    7075-T6 (seed Table 3), a 20 mm x 20 mm block, 2 mV/V rated output,
    mounted with the centre of its gap at the middle of the link.
    """

    capacity_kg: float = 50.0
    rated_deflection: float = 0.5e-3  #: [m] far-face deflection at capacity
    length: float = 0.040  #: [m] the gap it bridges
    position: float = 0.5  #: centre of the gap as a fraction of the link length from B
    block: RectangularSection = field(default_factory=lambda: RectangularSection(0.020, 0.020))
    material: Material = AL_7075_T6
    rated_output_mV_V: float = 2.0  #: bridge output at capacity [mV/V]
    crosstalk_axial: float = 0.0  #: output per rated output, per unit N / F_cap
    crosstalk_moment: float = 0.0  #: output per rated output, per unit M / (F_cap L)
    compliance: str = "datasheet"  #: one of :data:`COMPLIANCE_MODELS`
    compliance_vv: float = 0.0  #: [m/N] far-face deflection per shear (``matrix`` only)
    compliance_vm: float = 0.0  #: [1/N] far-face deflection per moment = rotation per shear (``matrix`` only)
    compliance_mm: float = 0.0  #: [1/(N m)] far-face rotation per moment (``matrix`` only)
    noise_mV_V: float = DEFAULT_NOISE_MV_V  #: 1-sigma reading noise [mV/V] (ADC and bridge), for resolution maps
    reading: str = ""  #: what the cells' readings are, one of :data:`READINGS`; "" lets each command use its default

    def __post_init__(self) -> None:
        for name in ("capacity_kg", "rated_deflection", "length", "rated_output_mV_V"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise GeometryError(f"load cell {name} = {value!r} must be a positive number")
        if self.reading not in ("", *READINGS):
            raise GeometryError(f"load cell reading = {self.reading!r}: expected one of {', '.join(map(repr, READINGS))}")
        if not (0.0 < self.position < 1.0):
            raise GeometryError(f"load cell position = {self.position!r} must lie strictly between 0 and 1")
        if not (isinstance(self.noise_mV_V, (int, float)) and math.isfinite(self.noise_mV_V) and self.noise_mV_V >= 0):
            raise GeometryError(f"load cell noise_mV_V = {self.noise_mV_V!r} must be a non-negative number")
        for name in ("crosstalk_axial", "crosstalk_moment"):
            if not math.isfinite(getattr(self, name)):
                raise GeometryError(f"load cell {name} must be finite")
        if self.compliance not in COMPLIANCE_MODELS:
            raise GeometryError(f"load cell compliance = {self.compliance!r}: expected one of {', '.join(COMPLIANCE_MODELS)}")
        for name in ("compliance_vv", "compliance_vm", "compliance_mm"):
            if not (isinstance(getattr(self, name), (int, float)) and math.isfinite(getattr(self, name))):
                raise GeometryError(f"load cell {name} = {getattr(self, name)!r} must be a finite number")
        vv, vm, mm = self.compliance_vv, self.compliance_vm, self.compliance_mm
        if self.compliance == "matrix" and not (vv > 0 and mm > 0 and vv * mm > vm * vm):
            raise GeometryError(
                f"load cell compliance matrix [[{vv:g}, {vm:g}], [{vm:g}, {mm:g}]] is not positive definite: "
                "it needs compliance_vv > 0, compliance_mm > 0 and compliance_vv x compliance_mm > compliance_vm^2"
            )
        if self.rated_deflection <= self.shear_deflection_at_capacity:
            raise GeometryError(
                f"load cell rated deflection {self.rated_deflection:g} m is not larger than the block's own "
                f"shear deflection {self.shear_deflection_at_capacity:g} m: the block section is too slender"
            )

    @property
    def capacity_N(self) -> float:
        """Rated capacity [N]."""
        return self.capacity_kg * STANDARD_GRAVITY

    @property
    def shear_rigidity(self) -> float:
        """kappa G A of the solid block [N]."""
        return self.block.shear_coefficient(self.material.nu) * self.material.G * self.block.area

    @property
    def shear_deflection_at_capacity(self) -> float:
        """F_cap L / (kappa G A) [m]."""
        return self.capacity_N * self.length / self.shear_rigidity

    @property
    def bending_rigidity(self) -> float:
        """The beam's E I [N m^2]: calibrated to the rated deflection, the block's own, or L / c_mm (module docstring)."""
        if self.compliance == "block":
            return self.material.E * self.block.second_moment
        if self.compliance == "matrix":
            return self.length / self.compliance_mm
        bending_part = self.rated_deflection - self.shear_deflection_at_capacity
        return self.capacity_N * self.length**3 / (3.0 * bending_part)

    @property
    def flexibility(self) -> np.ndarray:
        """C, the far face's (v, r) per (V, M) with the near face clamped, ``(2, 2)`` (module docstring)."""
        if self.compliance == "matrix":
            vv, vm, mm = self.compliance_vv, self.compliance_vm, self.compliance_mm
            return np.array([[vv, vm], [vm, mm]])
        L, EI = self.length, self.bending_rigidity
        return np.array([[L**3 / (3.0 * EI) + L / self.shear_rigidity, L**2 / (2.0 * EI)], [L**2 / (2.0 * EI), L / EI]])

    @property
    def axial_rigidity(self) -> float:
        """E A of the solid block [N]."""
        return self.material.E * self.block.area

    def bridge_signal(self, shear, axial, moment):
        """Bridge output [mV/V] for the internal forces through the cell.

        signal = S (V + c_N N + c_M M / L) / F_cap, with S the rated output,
        V the shear [N], N the axial force [N], M the bending moment at the
        cell's centre [N m].  An ideal bending-beam cell (c_N = c_M = 0)
        responds to shear only, which is why it reads T_i / l_i on a
        pin-jointed arm (docs/errata.md).
        """
        load = shear + self.crosstalk_axial * axial + self.crosstalk_moment * moment / self.length
        return self.rated_output_mV_V * load / self.capacity_N
