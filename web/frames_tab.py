"""The Frames tab: the robot's task frames listed with their poses, one added at the tool's pose or
a typed one (origin in mm, rotation vector in deg from base axes), an operator's deleted, and
their axes shown or hidden in 3D (robot_sim/task_frames.py)."""

from typing import Any

import mujoco
import numpy as np
import viser

from web.markup import add_html, show
from web.panel_html import frames_html
from web.typed_number import DEG, MM, TypedVector

FRAME_NAME_HINT = "letters, digits and _, starting with a letter (up to 32)"


class FramesTab:
    def __init__(self, gui: viser.GuiApi) -> None:
        self.frames_list = add_html(gui, frames_html([]))
        self.new_frame_name = gui.add_text("New frame name", "frame1", hint=FRAME_NAME_HINT)
        self.add_frame_at_tool = gui.add_button(
            "Add at tool pose", color="teal", disabled=True, hint="the port's pose as the robot has it now"
        )
        self.new_frame_position = TypedVector(
            gui, "frame-origin", "Typed origin [mm]", (400.0, 0.0, 300.0), MM
        )
        self.new_frame_rotation = TypedVector(
            gui,
            "frame-rotation",
            "Typed rotation [deg]",
            (0.0, 0.0, 0.0),
            DEG,
            hint="rotation vector from base axes",
        )
        self.add_frame_typed = gui.add_button("Add typed pose", color="teal", disabled=True)
        self.delete_frame_name = gui.add_dropdown("Delete frame", ("(none)",), initial_value="(none)")
        self.delete_frame = gui.add_button("Delete", color="red", disabled=True)
        self.show_frames = gui.add_checkbox("Show frames in 3D", True)

    def typed_pose_changed(self) -> None:
        self.new_frame_position.show()
        self.new_frame_rotation.show()

    def show_known(self, frames: list[dict[str, Any]]) -> None:
        """Listed with their poses; deletable if an operator's."""
        deletable = [f["name"] for f in frames if f["source"] == "operator"] or ["(none)"]
        self.delete_frame_name.options = deletable
        show(self.frames_list, frames_html(frames))

    def refresh_buttons(self, mine: bool) -> None:
        """Frames change what commands mean: only the operator in control adds or deletes them."""
        self.add_frame_at_tool.disabled = not mine
        typed_pose = (self.new_frame_position, self.new_frame_rotation)
        self.add_frame_typed.disabled = not mine or any(t.reason for t in typed_pose)
        self.delete_frame.disabled = not mine or self.delete_frame_name.value == "(none)"

    def typed_pose(self) -> dict[str, list[float]]:
        """The typed pose in the API's units: origin [m], axes as a quaternion from the rotation
        vector; FieldError if either is not three numbers."""
        quaternion = np.array([1.0, 0.0, 0.0, 0.0])
        mujoco.mju_quatIntegrate(quaternion, np.asarray(self.new_frame_rotation.si, dtype=float), 1.0)
        return {"position": self.new_frame_position.si, "quaternion": quaternion.tolist()}
