"""The Dither tab (paper Fig. 2): a preset fills every field, in the units of its mode (amplitude
in degrees torsional, millimetres translational); every field is sent explicitly."""

from typing import Any

import viser

from web.markup import add_html
from web.panel_html import check_html
from web.ptwl_settings import BUILT_IN_FRAMES, MONITOR_HINT
from web.ptwl_tab import FRAME_HINT
from web.request_tab import RequestTab, Typed, set_value
from web.typed_number import (
    DEG,
    HERTZ,
    MM,
    NEWTON_METRES,
    NEWTONS,
    PLAIN,
    SECONDS,
    TypedNumber,
    TypedVector,
    Unit,
)

AMPLITUDE_LABELS = {"torsional": "Amplitude [deg]", "translational": "Amplitude (radius) [mm]"}
# The API's amplitude is rad or m by mode; its rules say "rad or m" for both, "m" for the radius.
AMPLITUDE_UNITS = {
    "torsional": Unit("deg", ("rad or m", "rad"), DEG.per_si),
    "translational": Unit("mm", ("rad or m", "m"), MM.per_si),
}


class DitherTab(RequestTab):
    behavior = "dither"

    def __init__(self, gui: viser.GuiApi, presets: dict[str, dict[str, Any]], preset: str) -> None:
        self.presets = presets
        names = list(presets)
        self.preset = gui.add_dropdown(
            "Dither preset", names, initial_value=preset if preset in names else names[0]
        )
        self.mode = gui.add_dropdown("Mode", ("torsional", "translational"))
        self.direction = gui.add_dropdown("Direction", ("push", "pull"))
        # The number fields by the API's name: a preset fills each, params() sends each.
        axis = TypedVector(gui, "dither-axis", "Axis", (0.0, 0.0, 1.0), PLAIN)
        self.typed: dict[str, Typed] = {"axis": axis}
        self.frame = gui.add_dropdown("Axis frame", BUILT_IN_FRAMES, initial_value="tool", hint=FRAME_HINT)
        for name, label, initial, unit in (
            ("amplitude", AMPLITUDE_LABELS["torsional"], 1.0, AMPLITUDE_UNITS["torsional"]),
            ("frequency", "Frequency [Hz]", 1.0, HERTZ),
            ("travel", "Travel [mm]", 10.0, MM),
            ("duration", "Dither duration [s]", 5.0, SECONDS),
            ("force_threshold", "Dither force limit [N]", 30.0, NEWTONS),
            ("torque_threshold", "Dither torque limit [N m]", 3.0, NEWTON_METRES),
        ):
            self.typed[name] = TypedNumber(gui, "dither-" + name.replace("_", "-"), label, initial, unit)
        self.monitor = gui.add_checkbox("Dither force task monitor", False, hint=MONITOR_HINT)
        self.check_line = add_html(gui, check_html("dither", "", []))
        self.send = gui.add_button("Send dither", color="blue", disabled=True)
        self.inputs = [self.preset, self.mode, self.direction, self.frame, self.monitor, *self.typed.values()]
        self.preset.on_update(lambda _: self.fill_fields())
        self.mode.on_update(lambda _: self._label_amplitude())
        self.fill_fields()

    def _label_amplitude(self) -> None:
        mode = str(self.mode.value)
        amplitude = self.typed["amplitude"]
        assert isinstance(amplitude, TypedNumber)
        amplitude.relabel(AMPLITUDE_LABELS[mode], AMPLITUDE_UNITS[mode])

    def fill_fields(self) -> None:
        """Every field of the chosen preset, in the units of its mode."""
        p = self.presets[str(self.preset.value)]
        set_value(self.mode, p["mode"])
        set_value(self.direction, p["direction"])
        self._label_amplitude()
        for name, typed in self.typed.items():
            if isinstance(typed, TypedVector):
                typed.value = [float(v) * typed.unit.per_si for v in p[name]]
            else:
                typed.value = p[name] * typed.unit.per_si

    def params(self) -> dict[str, Any]:
        """Every field explicit (the preset's name is not sent: what is shown is what runs);
        FieldError while a field's text is not a number."""
        return {
            "mode": str(self.mode.value),
            "direction": str(self.direction.value),
            "frame": str(self.frame.value),
            **{name: typed.si for name, typed in self.typed.items()},
            **({"monitor": {}} if self.monitor.value else {}),
        }
