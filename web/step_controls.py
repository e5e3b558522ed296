"""IPSE's preview and step for the PTWL (the teleoperation paper): see the move run on the ground
twin first, then send it a part at a time."""

from typing import Any

import viser

from web.markup import add_html
from web.panel_html import preview_html
from web.typed_number import PERCENT, FieldError, TypedNumber

PREVIEW_HINT = (
    "run this PTWL on the ground twin, from where it puts the robot now, to its exit; nothing is sent"
)
STEP_HINT = "send only the first part: displacement and duration times the step (repeat to walk on)"
STEP_RANGE = "must be in (0, 100] %"  # the console's own notion: a part of the move


class StepControls:
    def __init__(self, gui: viser.GuiApi) -> None:
        self.preview = gui.add_button("Preview", color="gray", hint=PREVIEW_HINT)
        self.preview_html = add_html(gui, preview_html(None))
        self.step_percent = TypedNumber(gui, "step", "Step [% of the move]", 25.0, PERCENT)
        self.send_step = gui.add_button("Send step", color="cyan", disabled=True, hint=STEP_HINT)
        self.step_percent.on_update(lambda _: self.check_step())

    def check_step(self) -> None:
        self.step_percent.clear()
        try:
            if not 0.0 < self.step_percent.value <= 100.0:
                self.step_percent.refuse(f"{STEP_RANGE}, got {self.step_percent.value:g}")
        except FieldError:
            pass  # its reason is its text's
        self.step_percent.show()

    def part_of(self, params: dict[str, Any]) -> dict[str, Any]:
        """The first part of a PTWL: displacement and duration scaled alike, so the attractor walks
        the first stretch of the same path at the same speed; FieldError while the step is wrong."""
        if self.step_percent.reason:
            raise FieldError(f"{self.step_percent.label}: {self.step_percent.reason}")
        part = self.step_percent.value / 100.0
        return {
            **params,
            "translation": [part * v for v in params["translation"]],
            "rotation": [part * v for v in params["rotation"]],
            "duration": params["duration"] * part,
        }

    def refresh(self, send_disabled: bool, valid: bool) -> None:
        """The same PTWL, a part of it; its preview runs what Send would send."""
        self.send_step.disabled = send_disabled or bool(self.step_percent.reason)
        self.preview.disabled = not valid
