"""What a geometry builder hands to the mesher: one OCC solid and its named surfaces (or a
``errors.KernelFailure`` when the kernel did not build the body meant)."""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Solid:
    volume: int  # OCC tag of the single solid
    surfaces: dict[str, list[int]]  # surface group name → OCC face tags
