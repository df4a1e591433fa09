"""One example of every beam section of the geometry library (``geometry.SECTIONS``), with its
dimensions in metres: the 1 m steel beams of the mode-selection study and, drawn 0.1 m long,
the gallery's picture."""
from __future__ import annotations

SECTIONS: dict[str, dict] = {
    "square": {"side": 0.05},
    "rectangle": {"width": 0.06, "height": 0.03},
    "circle": {"radius": 0.025},
    "tube": {"radius": 0.03, "thickness": 0.006},
    "box": {"width": 0.06, "height": 0.04, "thickness": 0.006},
    "I": {"width": 0.05, "height": 0.06, "flange_thickness": 0.008, "web_thickness": 0.006},
    "T": {"width": 0.05, "height": 0.06, "flange_thickness": 0.008, "web_thickness": 0.006},
    "C": {"width": 0.05, "height": 0.06, "flange_thickness": 0.008, "web_thickness": 0.006},
    "L": {"width": 0.05, "height": 0.04, "thickness": 0.008},
    # no symmetry at all: an irregular pentagon
    "polygon": {"vertices": [[0.0, 0.0], [0.055, 0.004], [0.048, 0.03], [0.02, 0.045],
                             [-0.006, 0.022]]},
}
