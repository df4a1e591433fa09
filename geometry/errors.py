"""Why a geometry cannot be built: errors that name the study key, its value and what is allowed.

The geometry package imports nothing of ``gcms_fenicsx``; the configuration layer turns a
:class:`GeometryError` into its own ``ConfigError`` with the same three parts, so a bad
geometry ends in the same one line as any other bad input.
"""
from __future__ import annotations

from typing import Any


class GeometryError(ValueError):
    """A geometry or mesh parameter the builder cannot use: ``key`` (e.g. "[geometry]
    thickness"), its ``value`` and what is ``allowed``."""

    def __init__(self, key: str, value: Any, allowed: str) -> None:
        self.key, self.value, self.allowed = key, value, allowed
        super().__init__(f"{key} = {value!r}: {allowed}")

    def __reduce__(self):  # picklable: it crosses process and MPI boundaries
        return (type(self), (self.key, self.value, self.allowed))


class KernelFailure(Exception):
    """The geometry kernel returned something other than the body meant (several solids
    after a fusion, a named surface that matches no face): like the bare ``Exception``
    Gmsh raises with the kernel's error, a geometry the kernel cannot build."""
