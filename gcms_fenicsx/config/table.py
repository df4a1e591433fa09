"""Reading and validating one TOML table of a study configuration.

Every stage reads its table through :class:`Table`, so every bad value fails
where it is first seen, with a message that names the table, the key, the value
and what is allowed, and a key nobody read (a typo) is an error, not a silent
default. This module is pure Python: no NumPy, no dolfinx.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any


class ConfigError(ValueError):
    """A configuration value that is missing, malformed or out of range."""

    def __init__(self, key: str, value: Any, allowed: str) -> None:
        self.key = key
        self.value = value
        self.allowed = allowed
        shown = "(missing)" if value is _MISSING else repr(value)
        super().__init__(f"{key} = {shown}: {allowed}")

    def __reduce__(self):  # picklable, so MPI can send it from the rank that saw it
        return (type(self), (self.key, self.value, self.allowed))

    @classmethod
    def missing(cls, key: str, allowed: str) -> "ConfigError":
        """A required key or table that is absent."""
        return cls(key, _MISSING, allowed)


class _Missing:
    def __repr__(self) -> str:
        return "(missing)"


_MISSING: Any = _Missing()


class Table:
    """One configuration table whose keys are read once each and then checked for leftovers.

    >>> t = Table("mesh", {"size": 0.01})
    >>> t.positive("size")
    0.01
    >>> t.finish()
    """

    def __init__(self, name: str, raw: Mapping[str, Any] | None) -> None:
        if raw is not None and not isinstance(raw, Mapping):
            raise ConfigError(f"[{name}]", raw, "must be a table")
        self.name = name
        self._raw: dict[str, Any] = dict(raw or {})
        self._read: set[str] = set()

    def key(self, key: str) -> str:
        """The qualified name used in messages, e.g. ``[geometry] side``."""
        return f"[{self.name}] {key}"

    def has(self, key: str) -> bool:
        return key in self._raw

    def error(self, key: str, value: Any, allowed: str) -> ConfigError:
        return ConfigError(self.key(key), value, allowed)

    def get(self, key: str, default: Any = _MISSING) -> Any:
        """The raw value; a key without default is required."""
        self._read.add(key)
        if key in self._raw:
            return self._raw[key]
        if default is _MISSING:
            raise self.error(key, _MISSING, "required")
        return default

    def number(self, key: str, default: Any = _MISSING, *, low: float | None = None,
               high: float | None = None, low_open: bool = False,
               high_open: bool = False) -> float:
        """A finite real number in [low, high] (open ends on request)."""
        value = self.get(key, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self.error(key, value, "must be a finite number")
        value = float(value)
        if low is not None and (value < low or (low_open and value == low)):
            raise self.error(key, value, _range_text(low, high, low_open, high_open))
        if high is not None and (value > high or (high_open and value == high)):
            raise self.error(key, value, _range_text(low, high, low_open, high_open))
        return value

    def positive(self, key: str, default: Any = _MISSING) -> float:
        """A finite number > 0 (lengths, sizes, moduli)."""
        value = self.get(key, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self.error(key, value, "must be a finite number > 0")
        if value <= 0:
            raise self.error(key, value, "must be > 0")
        return float(value)

    def integer(self, key: str, default: Any = _MISSING, *, low: int | None = None,
                high: int | None = None) -> int:
        value = self.get(key, default)
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(key, value, "must be an integer")
        if (low is not None and value < low) or (high is not None and value > high):
            raise self.error(key, value, _range_text(low, high, False, False))
        return value

    def boolean(self, key: str, default: Any = _MISSING) -> bool:
        value = self.get(key, default)
        if not isinstance(value, bool):
            raise self.error(key, value, "must be true or false")
        return value

    def choice(self, key: str, allowed: Sequence[Any], default: Any = _MISSING) -> Any:
        value = self.get(key, default)
        if value not in allowed:
            raise self.error(key, value, "must be one of " + ", ".join(repr(a) for a in allowed))
        return value

    def number_list(self, key: str, default: Any = _MISSING) -> list[float]:
        value = self.get(key, default)
        if not _finite_numbers(value):
            raise self.error(key, value, "must be a list of finite numbers")
        return [float(v) for v in value]

    def vector(self, key: str, default: Any = _MISSING, length: int = 3) -> tuple[float, ...]:
        """A list of exactly ``length`` finite numbers (a 3-vector by default)."""
        value = self.get(key, default)
        if not _finite_numbers(value) or len(value) != length:
            raise self.error(key, value, f"must be a list of {length} finite numbers")
        return tuple(float(v) for v in value)

    def direction(self, key: str, default: Any = _MISSING) -> tuple[float, ...]:
        """The unit 3-vector along a finite, non-zero one (scaled by its largest component
        first, so that neither a huge nor a tiny vector over- or underflows)."""
        value = self.vector(key, default)
        big = max(abs(v) for v in value)
        if big == 0.0:
            raise self.error(key, list(value), "must be a non-zero vector")
        scaled = [v / big for v in value]
        norm = math.sqrt(sum(v * v for v in scaled))
        return tuple(v / norm for v in scaled)

    def string_list(self, key: str, default: Any = _MISSING) -> list[str]:
        value = self.get(key, default)
        if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
            raise self.error(key, value, "must be a list of strings")
        return list(value)

    def tables(self, key: str) -> list[Table]:
        """An array of tables (``[[name.key]]`` in TOML), each as a :class:`Table` named
        ``name.key[i]``; an empty list when the key is absent."""
        value = self.get(key, [])
        if not isinstance(value, (list, tuple)) or not all(isinstance(v, Mapping) for v in value):
            raise self.error(key, value, f"must be an array of tables ([[{self.name}.{key}]])")
        return [Table(f"{self.name}.{key}[{i}]", v) for i, v in enumerate(value)]

    def subtable(self, key: str) -> Mapping[str, Any]:
        value = self.get(key, {})
        if not isinstance(value, Mapping):
            raise self.error(key, value, "must be a table")
        return value

    def finish(self) -> None:
        """Reject every key that was given but never read."""
        unknown = sorted(set(self._raw) - self._read)
        if unknown:
            allowed = ", ".join(sorted(self._read)) or "none"
            raise self.error(unknown[0], self._raw[unknown[0]],
                             f"unknown key here (allowed: {allowed})")


def _range_text(low: float | None, high: float | None, low_open: bool, high_open: bool) -> str:
    parts = []
    if low is not None:
        parts.append(f"{'>' if low_open else '>='} {low:g}")
    if high is not None:
        parts.append(f"{'<' if high_open else '<='} {high:g}")
    return "must be " + " and ".join(parts)


def _finite_numbers(value: Any) -> bool:
    """A list (or tuple) of finite real numbers, booleans excluded."""
    return isinstance(value, (list, tuple)) and all(
        isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
        for v in value)
