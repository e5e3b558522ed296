"""Intent markers the operator can see: a tool-shaped target (not a 12 mm dot), a line from the
port to it with the distance written on it, and labels that are drawn over any fixture
(viser draws labels without a depth test) and placed so they do not overlap. The markers are
opaque: three.js draws opaque meshes before the see-through fixtures (robot_view.py), so a target
inside a plate shows through it.

A target pose is the port's: the marker's tip sits on it and its shaft runs back along -z, the
way the real tool extends behind its port.
"""

import numpy as np
import trimesh
import viser

from robot_sim.behaviors.base import PoseArrays
from web.label_places import MIN_DISTANCE_LABEL_MM, Anchor, LabelPlace

MOVE_EPSILON = 1e-5  # [m] and quaternion units: below this a pose is not re-sent
TIP_RADIUS_M = 0.008
SHAFT_RADIUS_M = 0.012
SHAFT_LENGTH_M = 0.09


def tool_mesh() -> trimesh.Trimesh:
    """A probe-like tool in its port frame: ball tip at the origin, shaft along -z."""
    tip = trimesh.creation.icosphere(subdivisions=2, radius=TIP_RADIUS_M)
    shaft = trimesh.creation.cylinder(radius=SHAFT_RADIUS_M, height=SHAFT_LENGTH_M, sections=20)
    shaft.apply_translation((0.0, 0.0, -TIP_RADIUS_M - SHAFT_LENGTH_M / 2.0))
    mesh = trimesh.util.concatenate([tip, shaft])
    assert isinstance(mesh, trimesh.Trimesh)
    return mesh


class TargetMarker:
    """A tool-shaped target with a label, and a port-to-target line whose label gives the distance."""

    def __init__(
        self,
        scene: viser.SceneApi,
        name: str,
        label: str,
        color: tuple[int, int, int],
        place: LabelPlace,
        wireframe: bool = False,
        distance_anchor: Anchor = "top-left",
    ) -> None:
        mesh = tool_mesh()
        self.frame = scene.add_frame(
            f"/{name}", show_axes=True, axes_length=0.04, axes_radius=0.0015, visible=False
        )
        self.tool = scene.add_mesh_simple(
            f"/{name}/tool",
            np.asarray(mesh.vertices, dtype=np.float32),
            np.asarray(mesh.faces, dtype=np.uint32),
            color=color,
            wireframe=wireframe,
        )
        self.label = scene.add_label(f"/{name}/label", label, position=place.offset_m, anchor=place.anchor)
        self.line = scene.add_line_segments(
            f"/{name}_line",
            np.zeros((1, 2, 3)),
            color,
            thickness=2.0,
            thickness_units="screen",
            visible=False,
        )
        self.distance = scene.add_label(f"/{name}_distance", "", visible=False, anchor=distance_anchor)
        self.distance_mm: float | None = None
        self._shown: np.ndarray | None = None  # (target, port) as last sent; None: hidden

    def show(self, target: PoseArrays | None, port: np.ndarray | None) -> None:
        """At `target` (position, wxyz), with the line from `port`; hidden for None. Called on
        every telemetry state: what has not moved is not re-sent (each assignment is a message)."""
        key = None
        if target is not None:
            where = port if port is not None else np.full(3, np.nan)
            key = np.concatenate([np.asarray(target[0], float), np.asarray(target[1], float), where])
        last, self._shown = self._shown, key
        if (key is None and last is None) or (
            key is not None
            and last is not None
            and bool(np.allclose(key, last, rtol=0.0, atol=MOVE_EPSILON, equal_nan=True))
        ):
            return
        visible = target is not None
        self.frame.visible = visible
        if target is None:
            self.line.visible = self.distance.visible = False
            self.distance_mm = None
            return
        position = np.asarray(target[0], dtype=float)
        self.frame.position, self.frame.wxyz = position, np.asarray(target[1], dtype=float)
        self.distance_mm = None if port is None else 1000.0 * float(np.linalg.norm(position - port))
        # No line and no "0.0 mm" on a target at the port: it would lie over the port's labels.
        far = self.distance_mm is not None and self.distance_mm >= MIN_DISTANCE_LABEL_MM
        self.line.visible = self.distance.visible = far
        if far and port is not None:
            self.line.points = np.stack([port, position])[None]
            self.distance.position = (port + position) / 2.0
            self.distance.text = f"{self.distance_mm:.1f} mm"
