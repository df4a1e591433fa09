"""The ``[modes]`` table: which free-free modes the eigen-solve returns, and how accurately:
``count`` (an integer, or "auto": the scene's band) or ``max_frequency_hz``. The study's plan
resolves "auto" and adds the attachment loads (``config.plan.modes_request``); the rules a
request applies to a spectrum — how many modes it takes, how it is named in messages — are
its methods, used by the solve and by the cache alike."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Mapping

from gcms_fenicsx.config.scene_band import Band

if TYPE_CHECKING:
    from gcms_fenicsx.config.basis import AttachmentLoad
from gcms_fenicsx.config.table import Table


@dataclass(frozen=True)
class ModesConfig:
    """What the free-free eigen-solve must return.

    Exactly one of ``count`` (number of elastic modes) and ``max_frequency_hz``
    (every elastic mode below it) is set. ``count = "auto"`` is ``max_frequency_hz`` set to
    the band of the study's scene (``config.scene_band``, given by the study as ``band``),
    with at least one mode kept.
    """

    count: int | None = 10
    max_frequency_hz: float | None = None
    tolerance: float = 1e-10
    max_iterations: int = 200
    band: Band | None = None
    attachment: tuple[AttachmentLoad, ...] | None = None   # from [basis] and the scene

    @property
    def auto(self) -> bool:
        return self.band is not None

    @property
    def cut(self) -> float | None:
        """(2π max_frequency_hz)², the eigenvalue a band ends at (rad²/s²); None for a count."""
        return None if self.max_frequency_hz is None else \
            (2.0 * math.pi * self.max_frequency_hz) ** 2

    def count_from(self, below_cut: int) -> int:
        """The elastic modes the request takes when ``below_cut`` elastic eigenvalues lie below
        its cut: ``count``; or, for a band, those, at least one with ``count = "auto"`` (the
        scene's band below the first mode keeps that one)."""
        if self.max_frequency_hz is None:
            assert self.count is not None
            return self.count
        return max(below_cut, 1) if self.auto else below_cut

    def named(self) -> tuple[str, object]:
        """The study key and value that asked for the modes, for messages."""
        if self.count is not None:
            return "[modes] count", self.count
        if self.band is not None:
            return "[modes] count", (f'"auto" (the band up to {self.band.max_frequency_hz:.4g} '
                                     f"Hz, set by the scene's {self.band.set_by})")
        return "[modes] max_frequency_hz", self.max_frequency_hz


def parse_modes(raw: Mapping[str, Any] | None) -> ModesConfig:
    t = Table("modes", raw)
    default = ModesConfig()
    if t.has("count") and t.has("max_frequency_hz"):
        raise t.error("max_frequency_hz", t.get("max_frequency_hz"),
                      "give either count or max_frequency_hz, not both")
    if t.has("max_frequency_hz"):
        count, fmax = None, t.positive("max_frequency_hz")
    elif t.get("count", default.count) == "auto":
        count, fmax = None, None   # the study sets the band from its scene
    elif isinstance(t.get("count", default.count), (str, bool, float)):
        raise t.error("count", t.get("count"), 'must be an integer ≥ 1 or "auto"')
    else:
        count, fmax = t.integer("count", default.count, low=1), None
    modes = ModesConfig(
        count=count,
        max_frequency_hz=fmax,
        tolerance=t.number("tolerance", default.tolerance, low=1e-15, high=1e-3),
        max_iterations=t.integer("max_iterations", default.max_iterations, low=1),
    )
    t.finish()
    return modes
