"""The commanded target, from Send until the robot reports the command done (after the
teleoperation paper): an outline while it is only predicted (a relative command resolves against
the port where it starts), solid red once the robot has said where it resolved it. Its line and
distance run from the port as last reported, so they follow the port as it moves."""

import numpy as np
import viser

from robot_sim.behaviors.base import PoseArrays
from web.label_places import COMMANDED
from web.markers import TargetMarker

RED = (224, 49, 49)


class CommandedMarker:
    """(not thread-safe: RobotView holds its lock around every call)"""

    def __init__(self, scene: viser.SceneApi) -> None:
        self.solid = TargetMarker(
            scene, "commanded", "commanded", RED, COMMANDED, distance_anchor="bottom-left"
        )
        self.outline = TargetMarker(
            scene,
            "predicted",
            "commanded: relative to port at start",
            RED,
            COMMANDED,
            wireframe=True,
            distance_anchor="bottom-left",
        )
        self._shown: tuple[PoseArrays | None, bool] = (None, False)  # (target, resolved)
        self._port: np.ndarray | None = None

    def marker(self, resolved: bool) -> TargetMarker:
        return self.solid if resolved else self.outline

    def show(self, target: PoseArrays | None, resolved: bool) -> None:
        """Solid where the robot resolved it, an outline where it is predicted; hidden for None."""
        self._shown = (target, resolved)
        self.marker(not resolved).show(None, None)
        self.marker(resolved).show(target, self._port)

    def port_moved(self, port_position: np.ndarray) -> None:
        self._port = port_position
        self.show(*self._shown)
