"""The ``[outputs]`` table: files a study asks for beyond what its stages need.

``mode_shapes = true`` writes the elastic mode shapes for ParaView (``mode_shapes/``,
binary XDMF + HDF5); by default nothing of the kind is written.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

from gcms_fenicsx.config.table import Table


@dataclass(frozen=True)
class OutputsConfig:
    """What a study asks to be written besides its stages' products."""

    mode_shapes: bool = False


def parse_outputs(raw: Mapping[str, Any] | None) -> OutputsConfig:
    t = Table("outputs", raw)
    cfg = OutputsConfig(mode_shapes=t.boolean("mode_shapes", OutputsConfig.mode_shapes))
    t.finish()
    return cfg
