"""The robot and fixtures as drawn: one viser frame per body and its meshes, built from the
server's geometry, greyed out with a STALE label while the state on screen cannot be trusted."""

import numpy as np
import viser

from server.models import GeometryModel
from web.meshes import MeshPart, body_parts

# Fixtures (the bodies that never move: plate, peg, stand) are drawn see-through, so a target
# inside or behind one stays in sight: the markers are opaque, drawn first, and show through.
FIXTURE_OPACITY = 0.55
STALE_GREY = (150, 150, 150)


class ArmBodies:
    """(not thread-safe: RobotView holds its lock around every call)"""

    def __init__(self, scene: viser.SceneApi) -> None:
        self._scene = scene
        self.frames: dict[str, viser.FrameHandle] = {}  # by body name, each moved by telemetry
        self._meshes: list[tuple[viser.MeshHandle, MeshPart]] = []
        self.stale = False
        self._stale_label = scene.add_label(
            "/stale", "STALE", position=(0.0, 0.0, 0.9), font_screen_scale=2.0, visible=False
        )

    def load(self, geometry: GeometryModel) -> None:
        """(Re)build the bodies for a scene, in grey if the picture is stale."""
        for handle in [*(m for m, _ in self._meshes), *self.frames.values()]:
            handle.remove()
        self._meshes, self.frames = [], {}
        parts = body_parts(geometry)
        for name, body in geometry.bodies.items():
            if name not in parts:
                continue
            node = "/robot/" + name.replace("/", "_")
            pose = np.asarray(body.pose, dtype=float)
            frame = self._scene.add_frame(node, show_axes=False, position=pose[0:3], wxyz=pose[3:7])
            self.frames[name] = frame
            for i, part in enumerate(parts[name]):
                handle = self._scene.add_mesh_simple(
                    f"{node}/mesh{i}",
                    np.asarray(part.mesh.vertices, dtype=np.float32),
                    np.asarray(part.mesh.faces, dtype=np.uint32),
                    color=STALE_GREY if self.stale else part.rgb,
                    opacity=drawn_opacity(part.opacity, body.moving),
                    cast_shadow=False,  # no shadow maps: robot_view.py's lights
                    receive_shadow=False,
                )
                self._meshes.append((handle, part))

    def opacities(self, node_prefix: str) -> list[float | None]:
        """The drawn opacity of each mesh under a scene node (what a test reads)."""
        return [handle.opacity for handle, _ in self._meshes if handle.name.startswith(node_prefix)]

    def set_stale(self, stale: bool, label: str) -> None:
        self.stale = stale
        self._stale_label.text = label
        self._stale_label.visible = stale
        for handle, part in self._meshes:
            handle.color = STALE_GREY if stale else part.rgb


def drawn_opacity(opacity: float, moving: bool) -> float | None:
    """The opacity a part is drawn with (None: opaque); fixtures never hide what is behind them."""
    shown = opacity if moving else min(opacity, FIXTURE_OPACITY)
    return shown if shown < 1.0 else None
