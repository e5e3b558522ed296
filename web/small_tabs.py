"""The RWE tab (a checkbox per axis, duration, frame), and the Tasks tab's two requests: a task's
onboard state machine, run as one command, and the tool tasks' gripper (paper 2.3.3-2.3.4)."""

from typing import Any

import viser

from web.markup import add_html, show
from web.panel_html import check_html, summary_html
from web.ptwl_settings import BUILT_IN_FRAMES
from web.ptwl_tab import FRAME_HINT
from web.request_tab import RequestTab, set_value
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


class TaskTab(RequestTab):
    behavior = "state_machine"

    def __init__(self, gui: viser.GuiApi, tasks: dict[str, str]) -> None:
        self.tasks = tasks
        names = list(tasks) or ["(none)"]
        self.task = gui.add_dropdown("Task", names, initial_value=names[0])
        self.summary = add_html(gui, summary_html(tasks.get(names[0], "")))
        self.check_line = add_html(gui, check_html("state_machine", "", []))
        self.send = gui.add_button(
            "Run state machine", color="blue", disabled=True, hint="STOP aborts it like any command"
        )
        self.inputs = [self.task]
        self.typed = {}
        self.task.on_update(lambda _: self._show_summary())

    def show_scene_task(self, scene: str) -> None:
        """Pick the loaded scene's task (each task's machine runs only on its own scene)."""
        if scene in self.tasks and self.task.value != scene:
            set_value(self.task, scene)
            self._show_summary()

    def _show_summary(self) -> None:
        show(self.summary, summary_html(self.tasks.get(str(self.task.value), "")))

    def params(self) -> dict[str, Any]:
        return {"task": str(self.task.value)}


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
