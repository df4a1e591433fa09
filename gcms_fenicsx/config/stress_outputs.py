"""``[scene.outputs] stress_groups`` and ``stress_times``: the stresses a scene asks for
(docs/design.md §9). A scene without them records no stress, and its study computes no
stress modes."""
from __future__ import annotations

from dataclasses import dataclass

from gcms_fenicsx.config.table import ConfigError, Table

#: ``stress_groups = "surface"``: every node on the body's surface.
SURFACE = "surface"


@dataclass(frozen=True)
class StressOutputs:
    """The nodes whose stresses are recorded — those of the named node groups, or
    (``surface``) every node on the body's surface — and the times at which the stress of
    the whole body is written."""

    groups: tuple[str, ...] = ()
    surface: bool = False
    times: tuple[float, ...] = ()

    @property
    def whole_body(self) -> bool:
        """Whether the whole body's stress is written (at ``times``): the stress modes then
        cover every node."""
        return bool(self.times)

    @property
    def labels(self) -> tuple[str, ...]:
        """The recorded groups' names ("surface" for the surface)."""
        return (SURFACE,) if self.surface else self.groups


def stress_outputs(o: Table, end: float) -> StressOutputs | None:
    """``stress_groups`` and ``stress_times`` of the ``[scene.outputs]`` table ``o`` of a scene
    ending at ``end`` s; None when neither is given."""
    if not (o.has("stress_groups") or o.has("stress_times")):
        return None
    times = tuple(o.number_list("stress_times", []))
    bad = [x for x in times if not 0.0 <= x <= end]
    if bad:
        raise o.error("stress_times", list(times), f"each must be within 0..end_time "
                      f"({end:g} s); {bad[0]:g} is not")
    allowed = (f'a non-empty list of node group names, or "{SURFACE}" (a string) for every '
               "surface node")
    if not o.has("stress_groups"):
        raise ConfigError.missing(o.key("stress_groups"), f"required with stress_times: {allowed}")
    raw = o.get("stress_groups")
    if raw == SURFACE:
        return StressOutputs(surface=True, times=times)
    if isinstance(raw, list) and SURFACE in raw:
        raise o.error("stress_groups", raw, f'"{SURFACE}" is not a group: write stress_groups '
                      f'= "{SURFACE}" (a string, not in a list) for every surface node')
    if not isinstance(raw, list) or not raw or \
            not all(isinstance(name, str) and name for name in raw):
        raise o.error("stress_groups", raw, allowed)
    return StressOutputs(groups=tuple(dict.fromkeys(raw)), times=times)
