"""The PTWL tab (paper Fig. 2): displacement in mm and deg in a frame, duration, thresholds,
tolerances, watchdog, gains frame and task monitor; Send, and IPSE's Preview and Send step."""

from collections.abc import Callable
from typing import Any

import numpy as np
import viser

from web.markup import add_html, show
from web.panel_html import check_html, contemplated_html, preview_html
from web.request_tab import RequestTab, Typed
from web.typed_number import (
    DEG,
    MM,
    NEWTON_METRES,
    NEWTONS,
    PERCENT,
    SECONDS,
    FieldError,
    TypedNumber,
    TypedVector,
)

BUILT_IN_FRAMES = ("tool", "base")
PRESET_FRAME = "(the preset's)"  # no gains_frame sent: the preset's own, as the robot decides
FRAME_HINT = "tool: the port's axes at start; base; or a task frame (Frames tab)"
GAINS_FRAME_HINT = "the axes K and B are diagonal in; a task frame's stay put as the tool turns"
MONITOR_HINT = (
    "learn the friction while sliding in contact (mu |F_n| + c) and end the command 'anomaly' "
    "on a jam or a change of surface; the plate's normal is base z"
)
PREVIEW_HINT = (
    "run this PTWL on the ground twin, from where it puts the robot now, to its exit; nothing is sent"
)
STEP_HINT = "send only the first part: displacement and duration times the step (repeat to walk on)"
STEP_RANGE = "must be in (0, 100] %"  # the console's own notion: a part of the move


class PtwlTab(RequestTab):
    behavior = "ptwl"

    def __init__(self, gui: viser.GuiApi, d: dict[str, Any], preset: Callable[[], str]) -> None:
        self._preset = preset  # the stiffness preset chosen below the tabs
        self.translation = TypedVector(gui, "translation", "Translation [mm]", d["translation_mm"], MM)
        self.rotation = TypedVector(gui, "rotation", "Rotation [deg]", d["rotation_deg"], DEG)
        self.frame = gui.add_dropdown("Frame", BUILT_IN_FRAMES, initial_value=d["frame"], hint=FRAME_HINT)
        self.duration = TypedNumber(gui, "duration", "Duration [s]", d["duration_s"], SECONDS)
        self.force_threshold = TypedNumber(
            gui, "force-threshold", "Force threshold [N]", d["force_threshold_n"], NEWTONS
        )
        self.torque_threshold = TypedNumber(
            gui, "torque-threshold", "Torque threshold [N m]", d["torque_threshold_nm"], NEWTON_METRES
        )
        self.show_gizmo = gui.add_checkbox("Drag target in 3D", False)
        self.contemplated_line = add_html(gui, contemplated_html(None, "no robot state yet"))
        self._contemplated = contemplated_html(None, "no robot state yet")
        # What is set once and left: folded away, so Send, Preview and Step stay in view.
        with gui.add_folder("Tolerances, watchdog, gains frame", expand_by_default=False):
            self.position_tolerance = TypedNumber(
                gui, "position-tolerance", "Position tolerance [mm]", d["position_tolerance_mm"], MM
            )
            self.orientation_tolerance = TypedNumber(
                gui,
                "orientation-tolerance",
                "Orientation tolerance [deg]",
                d["orientation_tolerance_deg"],
                DEG,
            )
            self.watchdog_auto = gui.add_checkbox(
                "Watchdog follows duration",
                True,
                hint="the robot's default: duration + 5 s; untick to set it",
            )
            self.watchdog = TypedNumber(
                gui, "watchdog", "Watchdog [s]", d["duration_s"] + 5.0, SECONDS, disabled=True
            )
            self.gains_frame = gui.add_dropdown(
                "Gains frame",
                (PRESET_FRAME, *BUILT_IN_FRAMES),
                initial_value=PRESET_FRAME,
                hint=GAINS_FRAME_HINT,
            )
            self.monitor = gui.add_checkbox("Force task monitor", False, hint=MONITOR_HINT)
        self.check_line = add_html(gui, check_html("ptwl", "", []))
        self.send = gui.add_button("Send cmd", color="blue", disabled=True)
        # IPSE's preview and step: see it run on the twin first; send it a part at a time.
        self.preview = gui.add_button("Preview", color="gray", hint=PREVIEW_HINT)
        self.preview_html = add_html(gui, preview_html(None))
        self.step_percent = TypedNumber(gui, "step", "Step [% of the move]", 25.0, PERCENT)
        self.send_step = gui.add_button("Send step", color="cyan", disabled=True, hint=STEP_HINT)
        self.inputs = [
            self.translation,
            self.rotation,
            self.frame,
            self.duration,
            self.force_threshold,
            self.torque_threshold,
            self.position_tolerance,
            self.orientation_tolerance,
            self.watchdog_auto,
            self.watchdog,
            self.gains_frame,
            self.monitor,
        ]
        self.typed = {
            "translation": self.translation,
            "rotation": self.rotation,
            "duration": self.duration,
            "force_threshold": self.force_threshold,
            "torque_threshold": self.torque_threshold,
            "position_tolerance": self.position_tolerance,
            "orientation_tolerance": self.orientation_tolerance,
            "watchdog": self.watchdog,
        }
        self.step_percent.on_update(lambda _: self.check_step())

    def in_use(self) -> dict[str, Typed]:
        """The watchdog only when typed (else the robot's duration + 5 s)."""
        if self.watchdog_auto.value:
            return {name: typed for name, typed in self.typed.items() if name != "watchdog"}
        return self.typed

    def check_step(self) -> None:
        self.step_percent.clear()
        try:
            if not 0.0 < self.step_percent.value <= 100.0:
                self.step_percent.refuse(f"{STEP_RANGE}, got {self.step_percent.value:g}")
        except FieldError:
            pass  # its reason is its text's
        self.step_percent.show()

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
            "translation": self.translation.si,
            "rotation": self.rotation.si,
            "frame": str(self.frame.value),
            "duration": self.duration.si,
            "force_threshold": self.force_threshold.si,
            "torque_threshold": self.torque_threshold.si,
            "position_tolerance": self.position_tolerance.si,
            "orientation_tolerance": self.orientation_tolerance.si,
            **({} if self.watchdog_auto.value else {"watchdog": self.watchdog.si}),
            "preset": self._preset(),
            **(
                {} if self.gains_frame.value == PRESET_FRAME else {"gains_frame": str(self.gains_frame.value)}
            ),
            **({"monitor": {}} if self.monitor.value else {}),  # the robot's default settings
        }

    def step_params(self) -> dict[str, Any]:
        """The first part of the PTWL (IPSE's step): displacement and duration scaled alike, so the
        attractor walks the first stretch of the same path at the same speed."""
        params = self.params()
        if self.step_percent.reason:
            raise FieldError(f"{self.step_percent.label}: {self.step_percent.reason}")
        part = self.step_percent.value / 100.0
        params["translation"] = [part * v for v in params["translation"]]
        params["rotation"] = [part * v for v in params["rotation"]]
        params["duration"] *= part
        return params

    def set_displacement(self, translation_m: np.ndarray, rotation_rad: np.ndarray) -> None:
        """Written as text to 0.01 mm and deg: what the fields then show is what is sent."""
        self.translation.value = [round(v * MM.per_si, 2) for v in np.asarray(translation_m, dtype=float)]
        self.rotation.value = [round(v * DEG.per_si, 2) for v in np.asarray(rotation_rad, dtype=float)]
