"""Stiffness and damping of the virtual attractor: diagonal in a chosen frame's axes."""

from dataclasses import dataclass
from typing import Literal

import numpy as np

GainsFrame = Literal["base", "tool"]


@dataclass(frozen=True)
class Gains:
    """Diagonal K and B. Order: x, y, z [N/m | N s/m], then rx, ry, rz [N m/rad | N m s/rad].

    `frame` names the axes the diagonal is in: `base` (robot base axes) or `tool` (the port's
    axes as they are now, so K and B turn with the tool: stiff along a tilted tool's axis and
    soft across it is one diagonal).
    """

    stiffness: np.ndarray  # (6,)
    damping: np.ndarray  # (6,)
    frame: GainsFrame = "base"

    @staticmethod
    def of(
        stiffness: "list[float] | np.ndarray", damping: "list[float] | np.ndarray", frame: GainsFrame = "base"
    ) -> "Gains":
        return Gains(
            np.asarray(stiffness, dtype=float).copy(), np.asarray(damping, dtype=float).copy(), frame
        )

    def in_frame(self, frame: GainsFrame) -> "Gains":
        """The same diagonal, in other axes."""
        return Gains(self.stiffness, self.damping, frame)

    def time_constants_s(self) -> np.ndarray:
        """Free-space first-order time constant B/K per axis of `frame` [s] (inf where K = 0)."""
        with np.errstate(divide="ignore"):
            return np.where(self.stiffness > 0, self.damping / self.stiffness, np.inf)
