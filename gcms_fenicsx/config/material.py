"""The body's material: isotropic linear elasticity in SI units, and its ``[material]`` table."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

from gcms_fenicsx.config.table import Table


@dataclass(frozen=True)
class Material:
    """Isotropic linear-elastic material in SI units (default: structural steel)."""

    E: float = 210e9
    nu: float = 0.3
    rho: float = 7850.0

    @property
    def lame(self) -> tuple[float, float]:
        """Lamé parameters (mu, lambda) = (E / 2(1+nu), E nu / ((1+nu)(1-2nu)))."""
        mu = self.E / (2.0 * (1.0 + self.nu))
        lmbda = self.E * self.nu / ((1.0 + self.nu) * (1.0 - 2.0 * self.nu))
        return mu, lmbda


def parse_material(raw: Mapping[str, Any] | None) -> Material:
    t = Table("material", raw)
    default = Material()
    material = Material(
        E=t.positive("E", default.E),
        nu=t.number("nu", default.nu, low=-1.0, high=0.5, low_open=True, high_open=True),
        rho=t.positive("rho", default.rho),
    )
    t.finish()
    return material
