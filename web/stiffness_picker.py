"""The stiffness preset under the tabs (paper 1, Fig. 2: a PTWL runs with the preset chosen),
with the preset's K, B and time constants written below it."""

from typing import Any

import viser

from web.markup import Markup, add_html, show
from web.panel_html import gains_html


class StiffnessPicker:
    def __init__(
        self, gui: viser.GuiApi, presets: dict[str, dict[str, Any]], initial: str | None, order: float
    ) -> None:
        self._presets = presets
        self.dropdown = gui.add_dropdown(
            "Stiffness preset (PTWL)",
            list(presets),
            initial_value=initial if initial in presets else next(iter(presets)),
            order=order,
        )
        self._info = add_html(gui, self._info_html(), order=order + 0.1)
        self.dropdown.on_update(lambda _: show(self._info, self._info_html()))

    @property
    def value(self) -> str:
        return str(self.dropdown.value)

    def _info_html(self) -> Markup:
        preset = self._presets[self.value]
        return gains_html(
            preset["stiffness"], preset["damping"], "ptwl-preset", preset.get("description", "")
        )
