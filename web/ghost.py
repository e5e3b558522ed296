"""The predictive display's drawing: the ground twin's robot (web/twin.py) as a translucent cyan
ghost beside the delayed one, with its port and a label saying how far its predictions have
been off (so the operator knows when to trust it)."""

import threading

import numpy as np
import trimesh
import viser

from server.models import GeometryModel
from web.label_places import GHOST
from web.meshes import body_parts
from web.sent_values import SentValues
from web.twin import Prediction

CYAN = (21, 170, 191)
GHOST_OPACITY = 0.35


class GhostView:
    def __init__(self, server: viser.ViserServer) -> None:
        self._server = server
        self._lock = threading.Lock()
        self._bodies: dict[str, viser.FrameHandle] = {}
        self._meshes: list[viser.MeshHandle] = []
        self._sent = SentValues()
        scene = server.scene
        self.port = scene.add_frame(
            "/twin_port", axes_length=0.05, axes_radius=0.003, origin_radius=0.005, visible=False
        )
        self.label = scene.add_label(
            "/twin_port/label", "predicted", position=GHOST.offset_m, anchor=GHOST.anchor
        )

    def load(self, geometry: GeometryModel) -> None:
        """The moving bodies of a (new) scene, each one translucent mesh."""
        with self._lock:
            for handle in [*self._meshes, *self._bodies.values()]:
                handle.remove()
            self._meshes, self._bodies = [], {}
            self._sent.clear()
            for name, parts in body_parts(geometry).items():
                body = geometry.bodies.get(name)
                if body is None or not body.moving:
                    continue
                node = "/twin/" + name.replace("/", "_")
                pose = np.asarray(body.pose, dtype=float)
                self._bodies[name] = self._server.scene.add_frame(
                    node, show_axes=False, position=pose[0:3], wxyz=pose[3:7], visible=False
                )
                mesh = trimesh.util.concatenate([p.mesh for p in parts])
                assert isinstance(mesh, trimesh.Trimesh)
                self._meshes.append(
                    self._server.scene.add_mesh_simple(
                        f"{node}/mesh",
                        np.asarray(mesh.vertices, dtype=np.float32),
                        np.asarray(mesh.faces, dtype=np.uint32),
                        color=CYAN,
                        opacity=GHOST_OPACITY,
                        cast_shadow=False,
                        receive_shadow=False,
                    )
                )

    def show(self, prediction: Prediction) -> None:
        """Move the ghost to a prediction (call inside server.atomic()); only what moved is sent.
        Its label is the status bar's to set (web/status_room.py), from the bar's one readout."""
        with self._lock:
            for name, pose in prediction.bodies.items():
                frame = self._bodies.get(name)
                if frame is not None:
                    self._place(name, frame, np.asarray(pose, dtype=float))
            position, wxyz = prediction.port
            self._place("/twin_port", self.port, np.concatenate([position, wxyz]))

    def set_label(self, text: str) -> None:
        """Say how far to trust the ghost (the bar's thread, each tick: the twin's own thread
        could not say it lags while it lags)."""
        with self._lock:
            if self.label.text != text:
                self.label.text = text

    def hide(self) -> None:
        """No ghost while the twin idles; the next show() places every part again."""
        with self._lock:
            for handle in (*self._bodies.values(), self.port):
                handle.visible = False
            self._sent.clear()  # so that the next show() sends every pose (and visibility) again

    def _place(self, key: str, handle: viser.FrameHandle, pose: np.ndarray) -> None:
        if self._sent.place(key, handle, pose):
            handle.visible = True
