"""How a step fails: Newton not converging or diverging, a state no longer finite, a matrix the
integrator must factorise that is singular to working precision. NumPy only."""
from __future__ import annotations

from gcms_fenicsx.runtime.errors import ComputationFailed


class IntegrationError(ComputationFailed):
    """Newton did not converge, the state stopped being finite, or the iteration matrix is
    singular: says when and how far."""

    def __init__(self, message: str, time_s: float) -> None:
        super().__init__(message)
        self.time_s = time_s

    def __reduce__(self):  # picklable, so MPI can send it from the rank that saw it
        return (type(self), (str(self), self.time_s))


class SingularMatrixError(IntegrationError):
    """A matrix the integrator must factorise is singular to working precision: its inverse
    defect |A A⁻¹ − I| and condition number (inf when the LU broke down)."""

    def __init__(self, defect: float, cond: float) -> None:
        self.defect, self.cond = float(defect), float(cond)
        super().__init__(f"matrix is numerically singular: {self.numbers}", 0.0)

    def __reduce__(self):
        return (type(self), (self.defect, self.cond))

    @property
    def numbers(self) -> str:
        return f"|A A^-1 - I| = {self.defect:.1e}, cond {self.cond:.1e}"
