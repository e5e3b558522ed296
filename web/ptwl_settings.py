"""The PTWL's set-once settings, folded away below its move so Send, Preview and Step stay in
view: tolerances, the watchdog (following the duration unless typed), the gains frame and the
task monitor."""

from typing import Any

import viser

from web.request_tab import Typed
from web.typed_number import DEG, MM, SECONDS, TypedNumber

BUILT_IN_FRAMES = ("tool", "base")
PRESET_FRAME = "(the preset's)"  # no gains_frame sent: the preset's own, as the robot decides
GAINS_FRAME_HINT = "the axes K and B are diagonal in; a task frame's stay put as the tool turns"
MONITOR_HINT = (
    "learn the friction while sliding in contact (mu |F_n| + c) and end the command 'anomaly' "
    "on a jam or a change of surface; the plate's normal is base z"
)
WATCHDOG_HINT = "the robot's default: duration + 5 s; untick to set it"


class PtwlSettings:
    def __init__(self, gui: viser.GuiApi, d: dict[str, Any]) -> None:
        with gui.add_folder("Tolerances, watchdog, gains frame", expand_by_default=False):
            # The number fields by the API's name.
            self.typed: dict[str, Typed] = {
                "position_tolerance": TypedNumber(
                    gui, "position-tolerance", "Position tolerance [mm]", d["position_tolerance_mm"], MM
                ),
                "orientation_tolerance": TypedNumber(
                    gui,
                    "orientation-tolerance",
                    "Orientation tolerance [deg]",
                    d["orientation_tolerance_deg"],
                    DEG,
                ),
            }
            self.watchdog_auto = gui.add_checkbox("Watchdog follows duration", True, hint=WATCHDOG_HINT)
            self.watchdog = TypedNumber(
                gui, "watchdog", "Watchdog [s]", d["duration_s"] + 5.0, SECONDS, disabled=True
            )
            self.typed["watchdog"] = self.watchdog
            self.gains_frame = gui.add_dropdown(
                "Gains frame",
                (PRESET_FRAME, *BUILT_IN_FRAMES),
                initial_value=PRESET_FRAME,
                hint=GAINS_FRAME_HINT,
            )
            self.monitor = gui.add_checkbox("Force task monitor", False, hint=MONITOR_HINT)
        self.choices = [self.watchdog_auto, self.gains_frame, self.monitor]  # the inputs not typed

    def in_use(self) -> dict[str, Typed]:
        """The watchdog only when typed (else the robot's duration + 5 s)."""
        if self.watchdog_auto.value:
            return {name: typed for name, typed in self.typed.items() if name != "watchdog"}
        return self.typed

    def chosen(self) -> dict[str, Any]:
        """What the choices add to the request (the number fields are the tab's to read)."""
        gains_frame = str(self.gains_frame.value)
        return {
            **({} if gains_frame == PRESET_FRAME else {"gains_frame": gains_frame}),
            **({"monitor": {}} if self.monitor.value else {}),  # the robot's default settings
        }

    def follow_duration(self, watchdog_s: float | None) -> None:
        """The robot's watchdog for the duration checked, shown while the watchdog follows it."""
        if watchdog_s is not None and self.watchdog_auto.value:
            self.watchdog.value = round(watchdog_s, 3)
        self.watchdog.disabled = bool(self.watchdog_auto.value)
