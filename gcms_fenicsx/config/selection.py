"""The ``[selection]`` table: which GCMS fields the reduction keeps (``reduction.selection``),
with explicit relative tolerances."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

from gcms_fenicsx.config.table import Table


@dataclass(frozen=True)
class SelectionConfig:
    """The ``[selection]`` table: explicit relative tolerances."""

    cosine_tolerance: float = 1e-12
    svd_tolerance: float = 1e-6
    weighting: str = "mass"
    orthonormalize: bool = True

    def to_json(self) -> dict:
        return {"cosine_tolerance": self.cosine_tolerance, "svd_tolerance": self.svd_tolerance,
                "weighting": self.weighting, "orthonormalize": self.orthonormalize}


def parse_selection(raw: Mapping[str, Any] | None) -> SelectionConfig:
    t = Table("selection", raw)
    d = SelectionConfig()
    cfg = SelectionConfig(
        cosine_tolerance=t.number("cosine_tolerance", d.cosine_tolerance, low=0.0, high=0.5),
        svd_tolerance=t.number("svd_tolerance", d.svd_tolerance, low=0.0, high=0.5),
        weighting=t.choice("weighting", ("mass", "euclidean"), d.weighting),
        orthonormalize=t.boolean("orthonormalize", d.orthonormalize),
    )
    t.finish()
    return cfg
