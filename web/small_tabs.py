"""The RWE tab (a checkbox per axis, duration, frame) and the Gripper tab: the tool tasks' gripper
(paper 2.3.3-2.3.4). A task's state machine is the Machines tab's (web/machines_tab.py)."""

from typing import Any

import viser

from web.markup import add_html
from web.panel_html import check_html
from web.ptwl_settings import BUILT_IN_FRAMES
from web.ptwl_tab import FRAME_HINT
from web.request_tab import RequestTab
from web.typed_number import SECONDS, TypedNumber

AXES = ("x", "y", "z", "rx", "ry", "rz")


class RweTab(RequestTab):
    behavior = "rwe"

    def __init__(self, gui: viser.GuiApi, d: dict[str, Any]) -> None:
        self.axes = {a: gui.add_checkbox(a, a in d["axes"]) for a in AXES}
        self.duration = TypedNumber(gui, "rwe-duration", "RWE duration [s]", d["duration_s"], SECONDS)
        self.frame = gui.add_dropdown("RWE frame", BUILT_IN_FRAMES, initial_value="base", hint=FRAME_HINT)
        self.check_line = add_html(gui, check_html("rwe", "", []))
        self.send = gui.add_button("Send RWE", color="blue", disabled=True)
        self.inputs = [*self.axes.values(), self.duration, self.frame]
        self.typed = {"duration": self.duration}

    def params(self) -> dict[str, Any]:
        return {
            "axes": [a for a, box in self.axes.items() if box.value],
            "duration": self.duration.si,
            "frame": str(self.frame.value),
        }


class GripperTab(RequestTab):
    behavior = "gripper"

    def __init__(self, gui: viser.GuiApi) -> None:
        # Refused by the robot on a scene whose tool has no gripper.
        self.action = gui.add_dropdown("Gripper", ("close", "open"), initial_value="close")
        self.check_line = add_html(gui, check_html("gripper", "", []))
        self.send = gui.add_button("Send gripper", color="blue", disabled=True)
        self.inputs = [self.action]
        self.typed = {}

    def params(self) -> dict[str, Any]:
        return {"action": str(self.action.value)}
