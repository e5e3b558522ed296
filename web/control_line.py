"""Who has control, on each browser's own form: "You have control", or who does and a button to
take it over (one operator sends at a time: web/seat.py)."""

import viser

from web.markup import add_html, show
from web.panel_html import control_html


class ControlLine:
    def __init__(self, gui: viser.GuiApi, order: float) -> None:
        self.mine = False
        self._line = add_html(gui, control_html(False, None), order=order)
        self.take_control = gui.add_button(
            "Take control", color="teal", hint="become the one operator who can send", order=order + 0.1
        )

    def show(self, mine: bool, holder: str | None) -> None:
        self.mine = mine
        self.take_control.visible = not mine
        show(self._line, control_html(mine, holder))
