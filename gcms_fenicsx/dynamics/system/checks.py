"""The checks an assembly's inputs go through where they enter: each refusal is a ValueError
that names the argument, the value given and what is allowed (docs/assemblies.md)."""
from __future__ import annotations

import math
from typing import Any

import numpy as np


def positive(name: str, value: Any) -> float:
    """A finite number > 0."""
    x = float(value)
    if not (math.isfinite(x) and x > 0):
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return x


def within(name: str, value: Any, low: float, high: float) -> float:
    """A finite number in [low, high]."""
    x = float(value)
    if not (math.isfinite(x) and low <= x <= high):
        raise ValueError(f"{name} must be in [{low:g}, {high:g}], got {value!r}")
    return x


def vector(name: str, value: Any, length: int = 3) -> np.ndarray:
    """A finite vector of ``length`` numbers."""
    x = np.asarray(value, float)
    if x.shape != (length,) or not np.isfinite(x).all():
        raise ValueError(f"{name} must be {length} finite numbers, got {value!r}")
    return x


def direction(name: str, value: Any) -> np.ndarray:
    """A finite non-zero 3-vector, made a unit vector."""
    x = vector(name, value)
    norm = float(np.linalg.norm(x))
    if not norm > 0:
        raise ValueError(f"{name} must be a non-zero direction, got {value!r}")
    return x / norm


def rotation(name: str, value: Any) -> np.ndarray:
    """A proper rotation matrix: RᵀR = I to 1e-9 and det R = +1."""
    R = np.asarray(value, float)
    if (R.shape != (3, 3) or not np.isfinite(R).all()
            or np.abs(R.T @ R - np.eye(3)).max() > 1e-9 or np.linalg.det(R) < 0):
        raise ValueError(f"{name} must be a rotation matrix (RᵀR = I to 1e-9, det R = +1), "
                         f"got {np.round(R, 6).tolist() if R.size == 9 else value!r}")
    return R


def known(kind: str, name: str, owner: str, names: Any) -> None:
    """``name`` is one of ``names`` (a KeyError-free refusal listing them)."""
    if name not in names:
        raise ValueError(f"{owner} has no {kind} {name!r}; its {kind}s are "
                         f"{sorted(names)}")
