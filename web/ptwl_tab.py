"""The PTWL tab (paper Fig. 2): displacement in mm and deg in a frame, duration, thresholds,
tolerances, watchdog, gains frame and task monitor; Send, and IPSE's Preview and Send step."""

from collections.abc import Callable
from typing import Any

import numpy as np
import viser

from web.markup import add_html, show
from web.panel_html import check_html, contemplated_html
from web.ptwl_settings import BUILT_IN_FRAMES, PtwlSettings
from web.request_tab import RequestTab, Typed
from web.step_controls import StepControls
from web.typed_number import DEG, MM, NEWTON_METRES, NEWTONS, SECONDS, FieldError, TypedNumber, TypedVector

FRAME_HINT = "tool: the port's axes at start; base; or a task frame (Frames tab)"


class PtwlTab(RequestTab):
    behavior = "ptwl"

    def __init__(self, gui: viser.GuiApi, d: dict[str, Any], preset: Callable[[], str]) -> None:
        self._preset = preset  # the stiffness preset chosen below the tabs
        self.translation = TypedVector(gui, "translation", "Translation [mm]", d["translation_mm"], MM)
        self.rotation = TypedVector(gui, "rotation", "Rotation [deg]", d["rotation_deg"], DEG)
        self.frame = gui.add_dropdown("Frame", BUILT_IN_FRAMES, initial_value=d["frame"], hint=FRAME_HINT)
        # The number fields by the API's name (the settings' too): where the robot's refusals are
        # said, and what params() sends.
        self.typed: dict[str, Typed] = {
            "translation": self.translation,
            "rotation": self.rotation,
            "duration": TypedNumber(gui, "duration", "Duration [s]", d["duration_s"], SECONDS),
            "force_threshold": TypedNumber(
                gui, "force-threshold", "Force threshold [N]", d["force_threshold_n"], NEWTONS
            ),
            "torque_threshold": TypedNumber(
                gui, "torque-threshold", "Torque threshold [N m]", d["torque_threshold_nm"], NEWTON_METRES
            ),
        }
        self.show_gizmo = gui.add_checkbox("Drag target in 3D", False)
        self.contemplated_line = add_html(gui, contemplated_html(None, "no robot state yet"))
        self._contemplated = contemplated_html(None, "no robot state yet")
        self.settings = PtwlSettings(gui, d)
        self.typed.update(self.settings.typed)
        self.check_line = add_html(gui, check_html("ptwl", "", []))
        self.send = gui.add_button("Send cmd", color="blue", disabled=True)
        self.step = StepControls(gui)
        self.inputs = [self.frame, *self.typed.values(), *self.settings.choices]

    def in_use(self) -> dict[str, Typed]:
        """The watchdog only when typed (else the robot's duration + 5 s)."""
        own = {name: typed for name, typed in self.typed.items() if name not in self.settings.typed}
        return own | self.settings.in_use()

    def show_contemplated(self, distance_mm: float | None, why_not: str) -> None:
        """The contemplated target as the 3D view draws it, in words: how far from the port, or
        why none is drawn (sent only when it changed: this follows every telemetry state)."""
        shown = contemplated_html(distance_mm, why_not)
        if shown != self._contemplated:
            self._contemplated = shown
            show(self.contemplated_line, shown)

    def values(self) -> tuple[np.ndarray, np.ndarray, str]:
        """(translation [m], rotation vector [rad], frame) where the contemplated target is drawn;
        FieldError while either is not numbers, or is what the robot's rules refuse (no target
        is shown for a move that will not be sent)."""
        for typed in (self.translation, self.rotation):
            if typed.reason:
                raise FieldError(f"{typed.label} is marked in red")
        return np.asarray(self.translation.si), np.asarray(self.rotation.si), str(self.frame.value)

    def params(self) -> dict[str, Any]:
        """The PTWL as typed, in SI; FieldError while a field's text is not a number."""
        return {
            **{name: typed.si for name, typed in self.in_use().items()},
            "frame": str(self.frame.value),
            "preset": self._preset(),
            **self.settings.chosen(),
        }

    def step_params(self) -> dict[str, Any]:
        """The first part of the PTWL (IPSE's step)."""
        return self.step.part_of(self.params())

    def set_displacement(self, translation_m: np.ndarray, rotation_rad: np.ndarray) -> None:
        """Written as text to 0.01 mm and deg: what the fields then show is what is sent."""
        self.translation.value = [round(v * MM.per_si, 2) for v in np.asarray(translation_m, dtype=float)]
        self.rotation.value = [round(v * DEG.per_si, 2) for v in np.asarray(rotation_rad, dtype=float)]
