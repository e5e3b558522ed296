"""The task frames in one browser's 3D view: each as red/green/blue axes (x, y, z) with its name,
so an operator sees which way "z in peg_axis" goes before sending a move in it."""

from typing import Any

import viser

AXES_LENGTH_M = 0.08  # longer than the markers' own axes (0.04 m): told apart at a glance
AXES_RADIUS_M = 0.003
# The name stands on the z axis' tip (8 mm beyond it, it seemed to float off on its own; on the
# origin, its box hid the x and y axes: labels are drawn over everything).
LABEL_OFFSET_M = (0.0, 0.0, AXES_LENGTH_M)


class FramesView:
    def __init__(self, scene: viser.SceneApi) -> None:
        self._scene = scene
        # Each frame's axes; its name label is their child, shown, hidden and removed with them.
        self._drawn: dict[str, viser.FrameHandle] = {}
        self._poses: dict[str, dict[str, Any]] = {}  # as last drawn: an unchanged frame sends nothing
        self._visible = True

    def show(self, frames: list[dict[str, Any]]) -> None:
        """Draw exactly these frames (as the API lists them); gone ones are removed. Only what
        changed goes to the browser: each property set is a message, and an add among 64 frames
        would otherwise resend all 64 poses."""
        wanted = {f["name"]: f for f in frames}
        for name in [n for n in self._drawn if n not in wanted]:
            self._poses.pop(name, None)
            self._drawn.pop(name).remove()  # its label too (removed again, viser warned)
        for name, frame in wanted.items():
            pose = frame["pose"]
            if self._poses.get(name) == pose:
                continue
            if name not in self._drawn:
                axes = self._scene.add_frame(
                    f"/task_frames/{name}",
                    axes_length=AXES_LENGTH_M,
                    axes_radius=AXES_RADIUS_M,
                    origin_radius=2 * AXES_RADIUS_M,
                    visible=self._visible,
                )
                self._scene.add_label(
                    f"/task_frames/{name}/label", name, position=LABEL_OFFSET_M, anchor="bottom-center"
                )
                self._drawn[name] = axes
            axes = self._drawn[name]
            axes.position, axes.wxyz = pose["position"], pose["quaternion"]
            self._poses[name] = pose

    def set_visible(self, visible: bool) -> None:
        self._visible = visible
        for axes in self._drawn.values():
            axes.visible = visible
