"""Materials and cross-sections (seed Tables 2 and 3)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from .errors import GeometryError


def shear_modulus(E: float, nu: float) -> float:
    """G = E / (2 (1 + nu)) for an isotropic material."""
    return E / (2.0 * (1.0 + nu))


@dataclass(frozen=True)
class Material:
    """An isotropic linear-elastic material [SI]."""

    name: str
    E: float  #: Young's modulus [Pa]
    nu: float  #: Poisson's ratio [-]
    rho: float  #: density [kg/m^3]
    yield_strength: float  #: [Pa]

    def __post_init__(self) -> None:
        for field in ("E", "rho", "yield_strength"):
            value = getattr(self, field)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise GeometryError(f"material {self.name}: {field} = {value!r} must be a positive number")
        if not (isinstance(self.nu, (int, float)) and -1.0 < self.nu < 0.5):
            raise GeometryError(f"material {self.name}: nu = {self.nu!r} must lie in (-1, 0.5)")

    @property
    def G(self) -> float:
        """Shear modulus [Pa]."""
        return shear_modulus(self.E, self.nu)


#: Seed Table 2's printed shear modulus [Pa] of the carbon steel, which E / 2(1 + nu) contradicts.
SEED_TABLE2_SHEAR_MODULUS = 7.9e10

#: Seed Table 2: plain carbon steel, for the links.  (The table's shear
#: modulus, :data:`SEED_TABLE2_SHEAR_MODULUS`, is close to E / 2(1 + nu) = 8.2e10 Pa;
#: we derive G from E and nu so the material stays self-consistent.)
CARBON_STEEL = Material("plain carbon steel (seed Table 2)", E=2.1e11, nu=0.28, rho=7800.0, yield_strength=220_594_000.0)

#: Seed Table 3: 7075-T6 aluminium, for the load cells.
AL_7075_T6 = Material("7075-T6 aluminium (seed Table 3)", E=7.2e10, nu=0.33, rho=2810.0, yield_strength=505_000_000.0)


@dataclass(frozen=True)
class RectangularSection:
    """A solid rectangle: ``depth`` in the plane of motion, ``thickness`` out of it [m]."""

    depth: float
    thickness: float

    def __post_init__(self) -> None:
        for field in ("depth", "thickness"):
            value = getattr(self, field)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise GeometryError(f"section {field} = {value!r} m must be a positive length")

    @property
    def area(self) -> float:
        """A [m^2]."""
        return self.depth * self.thickness

    @property
    def second_moment(self) -> float:
        """I about the out-of-plane axis, b h^3 / 12 [m^4]."""
        return self.thickness * self.depth**3 / 12.0

    @property
    def section_modulus(self) -> float:
        """S = I / (h / 2) [m^3]: extreme-fibre bending stress is M / S."""
        return self.thickness * self.depth**2 / 6.0

    def shear_coefficient(self, nu: float) -> float:
        """Timoshenko shear coefficient of a rectangle, kappa = 10 (1 + nu) / (12 + 11 nu).

        Cowper, "The shear coefficient in Timoshenko's beam theory", J. Appl.
        Mech. 33 (1966) 335-340; tends to 5/6 as nu -> 0.
        """
        return 10.0 * (1.0 + nu) / (12.0 + 11.0 * nu)
