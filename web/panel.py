"""The control panel of the paper's Fig. 2: PTWL, RWE, Dither, Frames, Machines and Gripper tabs over a
stiffness preset, and who has control.

Each tab is its own class (web/ptwl_tab.py, web/dither_tab.py, web/small_tabs.py,
web/frames_tab.py); the panel treats the requests alike through `RequestTab`. Fields are in
operator units (mm, deg); a request is made only from text that reads as a number, else
FieldError (web/typed_number.py), and the robot's rules' refusals are said at the field they
concern, in its units. The panel only builds widgets and reads them; what a click does is wired
by the desk, which keeps this file free of robot and link logic.
"""

from typing import Any

import viser

from web.checks import Check
from web.control_line import ControlLine
from web.defaults import ConsoleDefaults
from web.dither_tab import DitherTab
from web.frames_tab import FramesTab
from web.machines_tab import MachinesTab
from web.markup import show
from web.panel_html import check_html, field_named
from web.ptwl_settings import BUILT_IN_FRAMES, PRESET_FRAME
from web.ptwl_tab import PtwlTab
from web.request_tab import RequestTab, Typed
from web.small_tabs import GripperTab, RweTab
from web.stiffness_picker import StiffnessPicker

FORM_ORDER = 10.0  # each browser's own form sits above the shared board (order 100+)


class Panel:
    """One browser's own form: every operator types into fields nobody else sees."""

    def __init__(
        self,
        gui: viser.GuiApi,
        defaults: ConsoleDefaults,
        stiffness_presets: dict[str, dict[str, Any]],
        dither_presets: dict[str, dict[str, Any]],
        tasks: dict[str, str],
    ) -> None:
        self.control = ControlLine(gui, order=FORM_ORDER)
        tabs = gui.add_tab_group(order=FORM_ORDER + 0.2)
        # Each request's tab sits in a form so Enter in any of its fields submits it: the desk
        # sends it as its Send button would (viser's page hotkeys are ignored inside text fields).
        self.forms: dict[str, viser.GuiFormHandle] = {}
        with tabs.add_tab("PTWL"), gui.add_form(None) as self.forms["ptwl"]:
            self.ptwl = PtwlTab(gui, defaults.ptwl, lambda: self.stiffness.value)
        with tabs.add_tab("RWE"), gui.add_form(None) as self.forms["rwe"]:
            self.rwe = RweTab(gui, defaults.rwe)
        with tabs.add_tab("Dither"), gui.add_form(None) as self.forms["dither"]:
            self.dither = DitherTab(gui, dither_presets, defaults.dither_preset)
        with tabs.add_tab("Frames"):  # task frames: named axes to command in (robot_sim/task_frames.py)
            self.frames = FramesTab(gui)
        with tabs.add_tab("Machines"):
            self.machines = MachinesTab(gui, tasks)
        with tabs.add_tab("Gripper"):
            self.gripper = GripperTab(gui)
        self.stiffness = StiffnessPicker(
            gui, stiffness_presets, defaults.stiffness_preset, order=FORM_ORDER + 0.3
        )
        self.ptwl.inputs.append(self.stiffness.dropdown)  # the PTWL sends its preset: a change rechecks
        self._requests: dict[str, RequestTab] = {
            tab.behavior: tab for tab in (self.ptwl, self.rwe, self.dither, self.machines, self.gripper)
        }
        self._valid = dict.fromkeys(self._requests, True)
        self.ptwl.step.step_percent.on_update(lambda _: self.refresh_buttons())
        for typed in (self.frames.new_frame_position, self.frames.new_frame_rotation):
            typed.on_update(lambda _: self._typed_pose_changed())

    @property
    def sends(self) -> dict[str, viser.GuiButtonHandle]:
        """Each request's Send button, by its `type`."""
        return {behavior: tab.send for behavior, tab in self._requests.items()}

    @property
    def send_buttons(self) -> tuple[Any, ...]:
        return tuple(self.sends.values())

    def params(self, behavior: str) -> dict[str, Any]:
        """The request `behavior`'s tab makes from its fields."""
        return self._requests[behavior].params()

    def fields(self, behavior: str) -> list[Any]:
        """The inputs whose values make up a behavior's request."""
        return self._requests[behavior].inputs

    def show_control(self, mine: bool, holder: str | None) -> None:
        """Enable sending only for the client that holds control; say who does."""
        self.control.show(mine, holder)
        self.refresh_buttons()

    def show_check(self, behavior: str, check: Check) -> None:
        """What the robot's own rules say of the request as typed: each refusal at its field, in
        its units, and all of them on the check line; Send is off while it is refused."""
        tab = self._requests[behavior]
        fields = tab.in_use()
        for typed in fields.values():
            typed.clear()
        said = []
        for item in check.by_field:
            at = fields.get(field_named(item, fields))
            if at is None:
                said.append(f"{item['field']}: {item['message']}")
                continue
            refusal = at.refuse(item["message"])
            named = "" if item["field"] == "body" else f"{item['field']}: "  # the message names it
            said.append(named + refusal)
        errors = "; ".join(said) or check.errors
        self._valid[behavior] = not errors
        self._show_reasons(tab)
        show(tab.check_line, check_html(behavior, errors, check.warnings))
        if behavior == "ptwl":
            self.ptwl.settings.follow_duration(getattr(check.params, "watchdog", None))
        self.refresh_buttons()

    def show_unreadable(self, behavior: str) -> None:
        """A field's text is not a number: nothing is checked or sent until it is; each such
        field says why, and the check line names them."""
        tab = self._requests[behavior]
        fields = tab.in_use()
        for typed in fields.values():
            typed.clear()  # judged on other text: the robot's words wait for a request to judge
        self._valid[behavior] = False
        self._show_reasons(tab)
        wrong = "; ".join(f"{t.label}: {t.reason}" for t in fields.values() if t.reason)
        show(tab.check_line, check_html(behavior, "", [], unreadable=wrong))
        self.refresh_buttons()

    def _show_reasons(self, tab: RequestTab) -> None:
        in_use: dict[str, Typed] = tab.in_use()
        for typed in tab.typed.values():
            typed.show(active=typed in in_use.values())
        self.ptwl.settings.follow_duration(None)

    def _typed_pose_changed(self) -> None:
        self.frames.typed_pose_changed()
        self.refresh_buttons()

    def refresh_buttons(self) -> None:
        for behavior, tab in self._requests.items():
            tab.send.disabled = not (self.control.mine and self._valid[behavior])
        self.ptwl.step.refresh(self.ptwl.send.disabled, self._valid["ptwl"])
        self.frames.refresh_buttons(self.control.mine)

    def show_frames_known(self, frames: list[dict[str, Any]]) -> None:
        """The robot's task frames: listed, offered in every frame field, deletable if an operator's."""
        names = list(dict.fromkeys([*BUILT_IN_FRAMES, *(f["name"] for f in frames)]))  # Mantine: no repeats
        for field in (self.ptwl.frame, self.rwe.frame, self.dither.frame):
            field.options = names  # viser keeps the value if it is still there, else takes the first
        self.ptwl.settings.gains_frame.options = [PRESET_FRAME, *names]
        self.frames.show_known(frames)
        self.refresh_buttons()

    def show_scene_task(self, scene: str) -> None:
        self.machines.show_scene_task(scene)
