"""The 3D scene: the robot and fixtures from the server's geometry, and the operator's markers.

Owns its viser handles (like viser's own ViserUrdf). Markers, after the two papers:
- port axes (where the robot is, delayed) and the attractor's axes (paper 1, Fig. 3c);
- a yellow ghost of the *contemplated* PTWL target, following the fields as they are typed;
- a red marker for the *commanded* target, from Send until the robot reports the command done;
- an arrow for the measured wrench's force.
"""

import numpy as np
import viser

from server.models import GeometryModel
from web.meshes import body_meshes
from web.targets import Pose

MOVE_EPSILON = 1e-5  # [m] and quaternion units: below this a pose is not re-sent
YELLOW = (250, 204, 21)
RED = (224, 49, 49)
FORCE_COLOR = (230, 119, 0)


class RobotView:
    def __init__(self, server: viser.ViserServer, arrow_m_per_n: float) -> None:
        self.server = server
        self.arrow_m_per_n = arrow_m_per_n
        self._bodies: dict[str, viser.FrameHandle] = {}
        self._meshes: list[object] = []
        self._sent: dict[str, np.ndarray] = {}
        scene = server.scene
        scene.set_up_direction("+z")
        scene.add_grid("/floor", width=2.0, height=2.0, cell_size=0.1, section_size=0.5)
        self.port = scene.add_frame("/port", axes_length=0.05, axes_radius=0.004, origin_radius=0.006)
        self.attractor = scene.add_frame(
            "/attractor",
            axes_length=0.08,
            axes_radius=0.0015,
            origin_radius=0.004,
            origin_color=(255, 80, 80),
        )
        scene.add_label("/attractor/label", "attractor", position=(0.0, 0.0, 0.012))
        self.contemplated = scene.add_frame(
            "/contemplated", axes_length=0.04, axes_radius=0.0015, origin_radius=0.007, origin_color=YELLOW
        )
        scene.add_icosphere("/contemplated/ghost", radius=0.012, color=YELLOW, opacity=0.35)
        self.commanded = scene.add_frame(
            "/commanded",
            axes_length=0.04,
            axes_radius=0.002,
            origin_radius=0.008,
            origin_color=RED,
            visible=False,
        )
        scene.add_label("/commanded/label", "commanded", position=(0.0, 0.0, -0.02))
        self.wrench = scene.add_arrows(
            "/wrench",
            np.zeros((1, 2, 3)),
            FORCE_COLOR,
            shaft_radius=0.003,
            head_radius=0.007,
            head_length=0.015,
        )

    # -------------------------------------------------------------- geometry
    def load(self, geometry: GeometryModel) -> None:
        """(Re)build the bodies for a scene."""
        for handle in [*self._meshes, *self._bodies.values()]:
            handle.remove()  # type: ignore[attr-defined]
        self._meshes, self._bodies = [], {}
        self._sent.clear()
        meshes = body_meshes(geometry)
        for name, body in geometry.bodies.items():
            if name not in meshes:
                continue
            node = "/robot/" + name.replace("/", "_")
            pose = np.asarray(body.pose, dtype=float)
            frame = self.server.scene.add_frame(node, show_axes=False, position=pose[0:3], wxyz=pose[3:7])
            self._bodies[name] = frame
            self._meshes.append(self.server.scene.add_mesh_trimesh(node + "/mesh", meshes[name]))

    # ------------------------------------------------------------ telemetry
    def update(self, state: dict) -> None:
        """Move everything to a telemetry state (call inside server.atomic()).

        Only what moved is sent: every assignment is a message to every browser."""
        for name, pose in state.get("bodies", {}).items():
            frame = self._bodies.get(name)
            if frame is not None:
                self._place(name, frame, pose[0:3], pose[3:7])
        port, attractor = state["port"], state["attractor"]
        self._place("/port", self.port, port["position"], port["quaternion"])
        self._place("/attractor", self.attractor, attractor["position"], attractor["quaternion"])
        start = np.asarray(port["position"], dtype=float)
        force = np.asarray(state["wrench"][0:3], dtype=float)
        arrow = np.stack([start, start + force * self.arrow_m_per_n])[None]
        if self._moved("/wrench", arrow.ravel()):
            self.wrench.points = arrow

    def _moved(self, key: str, values: np.ndarray) -> bool:
        last = self._sent.get(key)
        if last is not None and float(np.max(np.abs(last - values))) < MOVE_EPSILON:
            return False
        self._sent[key] = values
        return True

    def _place(self, key: str, handle: viser.FrameHandle, position: list, wxyz: list) -> None:
        pose = np.array([*position, *wxyz], dtype=float)
        if self._moved(key, pose):
            handle.position = pose[0:3]
            handle.wxyz = pose[3:7]

    def show_contemplated(self, target: Pose | None) -> None:
        self.contemplated.visible = target is not None
        if target is not None:
            self.contemplated.position, self.contemplated.wxyz = target

    def show_commanded(self, target: Pose | None) -> None:
        self.commanded.visible = target is not None
        if target is not None:
            self.commanded.position, self.commanded.wxyz = target
