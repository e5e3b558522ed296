"""The 3D scene: the robot and fixtures from the server's geometry, and the operator's markers.

Owns its viser handles (like viser's own ViserUrdf). Shared by every browser; each browser's
own contemplated target lives on its desk. Markers, after the two papers:
- port axes (where the robot is, delayed) and the attractor's axes (paper 1, Fig. 3c);
- the *commanded* target, from Send until the robot reports the command done: an outline while it
  is only predicted (a relative command resolves against the port where it starts), solid red once
  the robot has said where it resolved it;
- an arrow for the measured wrench's force;
- grey robot with a STALE label when the state on screen can no longer be trusted.
"""

import threading

import numpy as np
import viser

from robot_sim.behaviors.base import PoseArrays
from server.models import GeometryModel
from web.arm_bodies import ArmBodies
from web.commanded_marker import CommandedMarker
from web.label_places import ATTRACTOR, PORT
from web.sent_values import SentValues

FORCE_COLOR = (200, 40, 210)  # magenta: the arm is orange, so an orange arrow on it hid


# The initial camera: looking at the workspace in front of the arm, from front-left and above
# ((eye, look-at) [m]; tests/test_label_layout.py lays the labels out for it).
INITIAL_CAMERA = ((1.05, -0.75, 0.75), (0.33, 0.0, 0.28))
FLOOR_SIZE_M = 1.2
FLOOR_CENTRE_M = (0.3, 0.0, 0.0)  # under the workspace, the arm's base (the origin) inside


class RobotView:
    def __init__(self, server: viser.ViserServer, arrow_m_per_n: float) -> None:
        self.server = server
        self.arrow_m_per_n = arrow_m_per_n
        # The telemetry thread moves bodies, the status bar greys them, a scene load replaces
        # them (the robot's first answer, a reset): one at a time, or one of them touches a
        # mesh another has just removed.
        self._lock = threading.RLock()
        self._sent = SentValues()
        scene = server.scene
        scene.set_up_direction("+z")
        # Without a GPU (software WebGL) shadow maps cost most of every frame; the lights stay.
        scene.configure_default_lights(enabled=True, cast_shadow=False)
        # viser's default image-based lighting is prefiltered in the browser: one 4-5 s frame in
        # software WebGL, just as the panels arrive, which held Send back past 7 s at 3 s RTT.
        # A sky/ground fill light stands in for it.
        scene.configure_environment_map(hdri=None)
        scene.add_light_hemisphere("/fill", sky_color=(255, 255, 255), ground_color=(90, 90, 100))
        # The floor grid is a per-pixel shader over all the screen it covers: in software WebGL a
        # 2 m grid cost a third of each frame while the arm moved (bench.console). 1.2 m under
        # the workspace keeps the 0.1 m scale where the work is.
        scene.add_grid(
            "/floor",
            width=FLOOR_SIZE_M,
            height=FLOOR_SIZE_M,
            cell_size=0.1,
            section_size=0.5,
            position=FLOOR_CENTRE_M,
        )
        self.port = scene.add_frame("/port", axes_length=0.05, axes_radius=0.004, origin_radius=0.006)
        self.attractor = scene.add_frame(
            "/attractor",
            axes_length=0.08,
            axes_radius=0.0015,
            origin_radius=0.004,
            origin_color=(255, 80, 80),
        )
        # Labels sit apart (web/label_places.py): none of them on another.
        for name, text, place in (("attractor", "attractor", ATTRACTOR), ("port", "port", PORT)):
            scene.add_label(f"/{name}/label", text, position=place.offset_m, anchor=place.anchor)
        self.commanded = CommandedMarker(scene)
        self.arm = ArmBodies(scene)
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
        with self._lock:
            self._load(geometry)

    def _load(self, geometry: GeometryModel) -> None:
        self._sent.clear()
        self.arm.load(geometry)

    # ------------------------------------------------------------ telemetry
    def update(self, state: dict) -> bool:
        """Move everything to a telemetry state (call inside server.atomic()); True if anything
        moved.

        Only what moved is sent: every assignment is a message to every browser."""
        with self._lock:
            return self._update(state)

    def _update(self, state: dict) -> bool:
        moved = False
        for name, pose in state.get("bodies", {}).items():
            frame = self.arm.frames.get(name)
            if frame is not None:
                moved |= self._place(name, frame, pose[0:3], pose[3:7])
        port, attractor = state["port"], state["attractor"]
        moved |= self._place("/port", self.port, port["position"], port["quaternion"])
        moved |= self._place("/attractor", self.attractor, attractor["position"], attractor["quaternion"])
        tip = np.asarray(port["position"], dtype=float)
        force = np.asarray(state["wrench"][0:3], dtype=float)
        # The environment's force on the port, drawn ending at the port: from outside the tool.
        arrow = np.stack([tip - force * self.arrow_m_per_n, tip])[None]
        if self._sent.moved("/wrench", arrow.ravel()):
            self.wrench.points = arrow
            moved = True
        if self._sent.moved("/port-line", tip):
            self.commanded.port_moved(tip)
        return moved

    def _place(self, key: str, handle: viser.FrameHandle, position: list, wxyz: list) -> bool:
        return self._sent.place(key, handle, np.array([*position, *wxyz], dtype=float))

    def show_commanded(self, target: PoseArrays | None, resolved: bool = False) -> None:
        """The commanded target: solid where the robot resolved it, an outline where it is only
        predicted from the delayed port; hidden for None."""
        with self._lock:
            self.commanded.show(target, resolved)

    @property
    def stale(self) -> bool:
        return self.arm.stale

    def set_stale(self, stale: bool, label: str = "STALE") -> None:
        """Grey the robot out (and say so) while its state cannot be trusted; colour it back after."""
        with self._lock:
            self.arm.set_stale(stale, label)
