"""What a geometry builder hands to the mesher: one OCC volume and its named surfaces, or
a :class:`KernelFailure` when the kernel did not build the body meant."""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Body:
    volume: int  # OCC tag of the single solid
    surfaces: dict[str, list[int]]  # surface group name → OCC face tags


class KernelFailure(Exception):
    """The geometry kernel returned something other than the body meant (several solids
    after a fusion, a named surface that matches no face): like the bare ``Exception``
    Gmsh raises with the kernel's error, a geometry the kernel cannot build."""
