"""The control panel of the paper's Fig. 2: PTWL, RWE and Dither tabs over a stiffness preset.

Fields are in operator units (mm, deg); `ptwl_params()` and friends turn them into the API's SI
request bodies. The panel only builds widgets and reads them; what a click does is wired by the
app, which keeps this file free of robot and link logic.
"""

import math
from typing import Any

import numpy as np
import viser

from web.defaults import ConsoleDefaults

AXES = ("x", "y", "z", "rx", "ry", "rz")
FORM_ORDER = 10.0  # each browser's own form sits above the shared board (order 100+)


class Panel:
    """One browser's own form: every operator types into fields nobody else sees."""

    def __init__(
        self,
        gui: viser.GuiApi,
        defaults: ConsoleDefaults,
        stiffness_presets: list[str],
        dither_presets: dict[str, dict[str, Any]],
    ) -> None:
        self.dither_presets = dither_presets
        self.control = gui.add_html(_control_html(False, None), order=FORM_ORDER)
        self.take_control = gui.add_button(
            "Take control", color="teal", hint="become the one operator who can send", order=FORM_ORDER + 0.1
        )
        tabs = gui.add_tab_group(order=FORM_ORDER + 0.2)
        d = defaults.ptwl
        with tabs.add_tab("PTWL"):
            self.translation = gui.add_vector3("Translation [mm]", tuple(d["translation_mm"]), step=0.1)
            self.rotation = gui.add_vector3("Rotation [deg]", tuple(d["rotation_deg"]), step=0.1)
            self.frame = gui.add_dropdown("Frame", ("tool", "base"), initial_value=d["frame"])
            self.duration = gui.add_number("Duration [s]", d["duration_s"], min=0.01, max=600.0, step=0.1)
            self.force_threshold = gui.add_number(
                "Force threshold [N]", d["force_threshold_n"], min=0.1, step=0.5
            )
            self.torque_threshold = gui.add_number(
                "Torque threshold [N m]", d["torque_threshold_nm"], min=0.01, step=0.05
            )
            self.position_tolerance = gui.add_number(
                "Position tolerance [mm]", d["position_tolerance_mm"], min=0.01, step=0.1
            )
            self.orientation_tolerance = gui.add_number(
                "Orientation tolerance [deg]", d["orientation_tolerance_deg"], min=0.01, step=0.1
            )
            self.watchdog = gui.add_number("Watchdog [s]", d["watchdog_s"], min=0.01, max=600.0, step=0.5)
            self.show_gizmo = gui.add_checkbox("Drag target in 3D", False)
            self.send_ptwl = gui.add_button("Send cmd", color="blue", disabled=True)
        with tabs.add_tab("RWE"):
            self.rwe_axes = {a: gui.add_checkbox(a, a in defaults.rwe["axes"]) for a in AXES}
            self.rwe_duration = gui.add_number(
                "RWE duration [s]", defaults.rwe["duration_s"], min=0.01, max=600.0
            )
            self.send_rwe = gui.add_button("Send RWE", color="blue", disabled=True)
        with tabs.add_tab("Dither"):
            names = list(dither_presets)
            first = defaults.dither_preset if defaults.dither_preset in names else names[0]
            self.dither_preset = gui.add_dropdown("Dither preset", names, initial_value=first)
            self.dither_axis = gui.add_vector3("Axis (tool frame)", (0.0, 0.0, 1.0), step=0.1)
            self.dither_amplitude = gui.add_number("Amplitude [deg or mm]", 1.0, min=0.001, step=0.1)
            self.dither_frequency = gui.add_number("Frequency [Hz]", 1.0, min=0.01, max=10.0, step=0.1)
            self.dither_travel = gui.add_number("Travel [mm]", 10.0, min=0.0, max=1000.0, step=0.5)
            self.dither_duration = gui.add_number("Dither duration [s]", 5.0, min=0.01, max=600.0, step=0.5)
            self.send_dither = gui.add_button("Send dither", color="blue", disabled=True)
            self.dither_preset.on_update(lambda _: self.fill_dither_fields())
            self.fill_dither_fields()

        initial = defaults.stiffness_preset if defaults.stiffness_preset in stiffness_presets else None
        self.stiffness = gui.add_dropdown(
            "Stiffness preset",
            stiffness_presets,
            initial_value=initial or stiffness_presets[0],
            order=FORM_ORDER + 0.3,
        )

    @property
    def send_buttons(self) -> tuple[Any, ...]:
        return (self.send_ptwl, self.send_rwe, self.send_dither)

    def show_control(self, mine: bool, holder: str | None) -> None:
        """Enable sending only for the client that holds control; say who does."""
        for button in self.send_buttons:
            button.disabled = not mine
        self.take_control.visible = not mine
        self.control.content = _control_html(mine, holder)

    # ------------------------------------------------------------ requests
    def ptwl_values(self) -> tuple[np.ndarray, np.ndarray, str]:
        """(translation [m], rotation vector [rad], frame) from the fields."""
        return (
            np.asarray(self.translation.value, dtype=float) / 1000.0,
            np.radians(np.asarray(self.rotation.value, dtype=float)),
            str(self.frame.value),
        )

    def ptwl_params(self) -> dict[str, Any]:
        translation, rotation, frame = self.ptwl_values()
        return {
            "translation": translation.tolist(),
            "rotation": rotation.tolist(),
            "frame": frame,
            "duration": float(self.duration.value),
            "force_threshold": float(self.force_threshold.value),
            "torque_threshold": float(self.torque_threshold.value),
            "position_tolerance": float(self.position_tolerance.value) / 1000.0,
            "orientation_tolerance": math.radians(float(self.orientation_tolerance.value)),
            "watchdog": float(self.watchdog.value),
            "preset": str(self.stiffness.value),
        }

    def set_ptwl_displacement(self, translation_m: np.ndarray, rotation_rad: np.ndarray) -> None:
        _set(self.translation, np.round(np.asarray(translation_m) * 1000.0, 2))
        _set(self.rotation, np.round(np.degrees(rotation_rad), 2))

    def rwe_params(self) -> dict[str, Any]:
        return {
            "axes": [a for a, box in self.rwe_axes.items() if box.value],
            "duration": float(self.rwe_duration.value),
        }

    def _dither_is_torsional(self) -> bool:
        return self.dither_presets[str(self.dither_preset.value)]["mode"] == "torsional"

    def fill_dither_fields(self) -> None:
        p = self.dither_presets[str(self.dither_preset.value)]
        _set(self.dither_axis, np.asarray(p["axis"], dtype=float))
        torsional = p["mode"] == "torsional"
        _set(
            self.dither_amplitude,
            round(math.degrees(p["amplitude"]) if torsional else p["amplitude"] * 1000, 3),
        )
        _set(self.dither_frequency, p["frequency"])
        _set(self.dither_travel, round(p["travel"] * 1000.0, 3))
        _set(self.dither_duration, p["duration"])

    def dither_params(self) -> dict[str, Any]:
        amplitude = float(self.dither_amplitude.value)
        return {
            "preset": str(self.dither_preset.value),
            "axis": list(self.dither_axis.value),
            "amplitude": math.radians(amplitude) if self._dither_is_torsional() else amplitude / 1000.0,
            "frequency": float(self.dither_frequency.value),
            "travel": float(self.dither_travel.value) / 1000.0,
            "duration": float(self.dither_duration.value),
        }


def _set(handle: Any, value: Any) -> None:
    """Assign a GUI input's value (a per-client handle: only this browser sees it)."""
    handle.value = value


def _control_html(mine: bool, holder: str | None) -> str:
    if mine:
        text, color = "You have control: your commands go to the robot.", "#2f9e44"
    elif holder:
        text, color = f"Watching: <b>{holder}</b> has control. Your fields are your own.", "#868e96"
    else:
        text, color = "Watching: nobody has control. Take it to send.", "#868e96"
    return (
        f'<div id="ptwl-control" data-mine="{int(mine)}" data-holder="{holder or ""}" '
        f'style="padding:4px 8px;border-left:6px solid {color}">{text}</div>'
    )
