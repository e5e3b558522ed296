"""Stiffness and damping of the virtual attractor, diagonal in base-frame axes."""

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Gains:
    """Diagonal K and B. Order: x, y, z [N/m | N s/m], then rx, ry, rz [N m/rad | N m s/rad]."""

    stiffness: np.ndarray  # (6,)
    damping: np.ndarray  # (6,)

    @staticmethod
    def of(stiffness: "list[float] | np.ndarray", damping: "list[float] | np.ndarray") -> "Gains":
        return Gains(np.asarray(stiffness, dtype=float).copy(), np.asarray(damping, dtype=float).copy())

    def time_constants_s(self) -> np.ndarray:
        """Free-space first-order time constant B/K per axis [s] (inf where K = 0)."""
        with np.errstate(divide="ignore"):
            return np.where(self.stiffness > 0, self.damping / self.stiffness, np.inf)
