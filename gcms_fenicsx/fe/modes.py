"""Free-free modes: the product of the eigen-solve stage, rigid first, then elastic ascending,
with the record of their verification."""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from gcms_fenicsx.fe.verification import Verification
from gcms_fenicsx.numerics import spectrum


@dataclass(frozen=True)
class Modes:
    """Free-free modes, rigid first, then elastic in ascending order.

    ``vectors`` holds this rank's owned rows (node-major, direction-minor) of the
    M-orthonormal mode shapes, one column per mode; ``attachment`` the same rows of the
    attachment modes (M-normalised, rigid content removed; none unless asked), one per
    label of ``attachment_labels``.
    """

    eigenvalues: np.ndarray
    vectors: np.ndarray
    rigid_count: int
    shift: float
    center_m: np.ndarray  # centre of mass the rotation fields are taken about
    verification: Verification
    timings_s: dict[str, float] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()
    attachment: np.ndarray | None = None
    attachment_labels: tuple[str, ...] = ()

    @property
    def elastic_eigenvalues(self) -> np.ndarray:
        return self.eigenvalues[self.rigid_count:]

    @property
    def elastic_vectors(self) -> np.ndarray:
        return self.vectors[:, self.rigid_count:]

    @property
    def elastic_frequencies_hz(self) -> np.ndarray:
        """f = √λ / 2π."""
        return np.sqrt(np.maximum(self.elastic_eigenvalues, 0.0)) / (2.0 * np.pi)

    @property
    def relative_residuals(self) -> np.ndarray:
        """‖Kφ − λMφ‖/‖Kφ‖ (rigid modes: over λ₇‖Mφ‖); reported, the check is the backward error."""
        return self.verification.relative_residuals

    @property
    def orthonormality_error(self) -> float:
        return self.verification.orthonormality_error

    @property
    def rigid_fractions(self) -> np.ndarray:
        return self.verification.rigid_fractions

    @property
    def inertia_count(self) -> int:
        return self.verification.inertia_count

    @property
    def missed_eigenvalues(self) -> int:
        """Eigenvalues below the check shift (Sylvester) minus eigenvalues of the solve: 0."""
        return self.verification.missed

    def lowest(self, count: int) -> "Modes":
        """The same solve restricted to its rigid modes and lowest ``count`` elastic modes."""
        keep = self.rigid_count + count
        return replace(self, eigenvalues=self.eigenvalues[:keep], vectors=self.vectors[:, :keep],
                       verification=self.verification.lowest(keep))

    def clusters(self) -> list[dict]:
        """Groups of neighbouring elastic eigenvalues (``numerics.spectrum.clusters``): a group
        whose spread is below REPEATED_SPLIT is a repeated eigenvalue of that multiplicity,
        a larger one near-repeated (a bending pair on a mesh that is not symmetric)."""
        return spectrum.clusters(self.elastic_eigenvalues)
