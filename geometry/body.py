"""What a geometry builder hands to the mesher: one OCC volume and its named surfaces."""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Body:
    volume: int  # OCC tag of the single solid
    surfaces: dict[str, list[int]]  # surface group name → OCC face tags
