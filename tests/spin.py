"""The centrifugal load of the default crankshaft's drive at full speed, for the statics tests."""
from __future__ import annotations

import numpy as np

from gcms_fenicsx.config.basis import AttachmentLoad
from gcms_fenicsx.dynamics.bases.rotor_basis import generalized_loads


def drive_spin(cfg, body) -> np.ndarray:
    """The generalized centrifugal load on ``body`` spinning at the angular velocity of the
    study's first joint's drive, about its axis (Ω² times the unit attachment load)."""
    drive = cfg.scene.joints[0]
    unit = AttachmentLoad(drive.group, "centrifugal", drive.axis)
    return drive.drive.angular_velocity ** 2 * generalized_loads(body, [unit])[:, 0]
