"""Stiffness and damping of the virtual attractor: diagonal in a chosen frame's axes."""

from dataclasses import dataclass
from typing import Literal

import numpy as np

GainsFrame = Literal["base", "tool"]


@dataclass(frozen=True)
class Gains:
    """Diagonal K and B. Order: x, y, z [N/m | N s/m], then rx, ry, rz [N m/rad | N m s/rad].

    `frame` names the axes the diagonal is in: `base` (robot base axes), `tool` (the port's
    axes as they are now, so K and B turn with the tool: stiff along a tilted tool's axis and
    soft across it is one diagonal), or a task frame (fixed axes: stiff along a peg's axis
    however the tool is held).
    """

    stiffness: np.ndarray  # (6,)
    damping: np.ndarray  # (6,)
    frame: str = "base"  # `base`, `tool` or a task frame's name (robot_sim/task_frames.py)
    # (3, 3) a task frame's axes in base axes (fixed); None for `base` and `tool`
    R_world_axes: np.ndarray | None = None

    @staticmethod
    def of(
        stiffness: "list[float] | np.ndarray", damping: "list[float] | np.ndarray", frame: GainsFrame = "base"
    ) -> "Gains":
        return Gains(
            np.asarray(stiffness, dtype=float).copy(), np.asarray(damping, dtype=float).copy(), frame
        )

    def in_frame(self, frame: str, R_world_axes: np.ndarray | None = None) -> "Gains":
        """The same diagonal, in other axes (a task frame's come with its rotation)."""
        return Gains(self.stiffness, self.damping, frame, R_world_axes)

    def same_spring_as(self, other: "Gains") -> bool:
        """The same stiffness in the same axes (damping aside)."""
        return (
            self.frame == other.frame
            and np.array_equal(self.stiffness, other.stiffness)
            and np.array_equal(self.fixed_axes_world(), other.fixed_axes_world())
        )

    def fixed_axes_world(self) -> np.ndarray:
        """(3, 3) the axes K and B are diagonal in, unless `tool` (which turn with the port)."""
        return np.eye(3) if self.R_world_axes is None else self.R_world_axes

    def time_constants_s(self) -> np.ndarray:
        """Free-space first-order time constant B/K per axis of `frame` [s] (inf where K = 0)."""
        with np.errstate(divide="ignore"):
            return np.where(self.stiffness > 0, self.damping / self.stiffness, np.inf)
