"""The control panel of the paper's Fig. 2: PTWL, RWE and Dither tabs over a stiffness preset.

Fields are in operator units (mm, deg); `ptwl_params()` and friends turn them into the API's SI
request bodies. Number fields hold exactly what was typed (web/typed_number.py): a request is
made only from text that reads as a number, else FieldError, and the robot's rules' refusals are
said at the field they concern, in its units. The panel only builds widgets and reads them; what
a click does is wired by the app, which keeps this file free of robot and link logic.
"""

import re
from typing import Any

import mujoco
import numpy as np
import viser
import viser.transforms as tf

from web.checks import Check
from web.defaults import ConsoleDefaults
from web.markup import Markup, add_html, show
from web.typed_number import (
    DEG,
    HERTZ,
    MM,
    NEWTON_METRES,
    NEWTONS,
    PERCENT,
    PLAIN,
    SECONDS,
    FieldError,
    TypedNumber,
    TypedVector,
    Unit,
)

AXES = ("x", "y", "z", "rx", "ry", "rz")
AMPLITUDE_LABELS = {"torsional": "Amplitude [deg]", "translational": "Amplitude (radius) [mm]"}
# The API's amplitude is rad or m by mode; its rules say "rad or m" for both, "m" for the radius.
AMPLITUDE_UNITS = {
    "torsional": Unit("deg", ("rad or m", "rad"), DEG.per_si),
    "translational": Unit("mm", ("rad or m", "m"), MM.per_si),
}
STEP_RANGE = "must be in (0, 100] %"  # the console's own notion: a part of the move
FORM_ORDER = 10.0
PREVIEW_HINT = (
    "run this PTWL on the ground twin, from where it puts the robot now, to its exit; nothing is sent"
)
STEP_HINT = "send only the first part: displacement and duration times the step (repeat to walk on)"
BUILT_IN_FRAMES = ("tool", "base")
PRESET_FRAME = "(the preset's)"  # no gains_frame sent: the preset's own, as the robot decides
FRAME_HINT = "tool: the port's axes at start; base; or a task frame (Frames tab)"
GAINS_FRAME_HINT = "the axes K and B are diagonal in; a task frame's stay put as the tool turns"
FRAME_NAME_HINT = "letters, digits and _, starting with a letter (up to 32)"
MONITOR_HINT = (
    "learn the friction while sliding in contact (mu |F_n| + c) and end the command 'anomaly' "
    "on a jam or a change of surface; the plate's normal is base z"
)  # each browser's own form sits above the shared board (order 100+)


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
        self.dither_presets = dither_presets
        self.tasks = tasks
        self.stiffness_presets = stiffness_presets
        self._mine = False
        self.control = add_html(gui, _control_html(False, None), order=FORM_ORDER)
        self.take_control = gui.add_button(
            "Take control", color="teal", hint="become the one operator who can send", order=FORM_ORDER + 0.1
        )
        tabs = gui.add_tab_group(order=FORM_ORDER + 0.2)
        d = defaults.ptwl
        # Each tab's fields sit in a form so Enter in any of them submits it: the desk sends it
        # as its Send button would (viser's page hotkeys are ignored inside text fields).
        self.forms: dict[str, viser.GuiFormHandle] = {}
        with tabs.add_tab("PTWL"), gui.add_form(None) as self.forms["ptwl"]:
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
            self.ptwl_check = add_html(gui, _check_html("ptwl", "", []))
            self.send_ptwl = gui.add_button("Send cmd", color="blue", disabled=True)
            # IPSE's preview and step: see it run on the twin first; send it a part at a time.
            self.preview = gui.add_button("Preview", color="gray", hint=PREVIEW_HINT)
            self.preview_html = add_html(gui, preview_html(None))
            self.step_percent = TypedNumber(gui, "step", "Step [% of the move]", 25.0, PERCENT)
            self.send_step = gui.add_button("Send step", color="cyan", disabled=True, hint=STEP_HINT)
        with tabs.add_tab("RWE"), gui.add_form(None) as self.forms["rwe"]:
            self.rwe_axes = {a: gui.add_checkbox(a, a in defaults.rwe["axes"]) for a in AXES}
            self.rwe_duration = TypedNumber(
                gui, "rwe-duration", "RWE duration [s]", defaults.rwe["duration_s"], SECONDS
            )
            self.rwe_frame = gui.add_dropdown(
                "RWE frame", BUILT_IN_FRAMES, initial_value="base", hint=FRAME_HINT
            )
            self.rwe_check = add_html(gui, _check_html("rwe", "", []))
            self.send_rwe = gui.add_button("Send RWE", color="blue", disabled=True)
        with tabs.add_tab("Dither"), gui.add_form(None) as self.forms["dither"]:
            names = list(dither_presets)
            first = defaults.dither_preset if defaults.dither_preset in names else names[0]
            self.dither_preset = gui.add_dropdown("Dither preset", names, initial_value=first)
            self.dither_mode = gui.add_dropdown("Mode", ("torsional", "translational"))
            self.dither_direction = gui.add_dropdown("Direction", ("push", "pull"))
            self.dither_axis = TypedVector(gui, "dither-axis", "Axis", (0.0, 0.0, 1.0), PLAIN)
            self.dither_frame = gui.add_dropdown(
                "Axis frame", BUILT_IN_FRAMES, initial_value="tool", hint=FRAME_HINT
            )
            self.dither_amplitude = TypedNumber(
                gui, "dither-amplitude", AMPLITUDE_LABELS["torsional"], 1.0, AMPLITUDE_UNITS["torsional"]
            )
            self.dither_frequency = TypedNumber(gui, "dither-frequency", "Frequency [Hz]", 1.0, HERTZ)
            self.dither_travel = TypedNumber(gui, "dither-travel", "Travel [mm]", 10.0, MM)
            self.dither_duration = TypedNumber(gui, "dither-duration", "Dither duration [s]", 5.0, SECONDS)
            self.dither_force_threshold = TypedNumber(
                gui, "dither-force-threshold", "Dither force limit [N]", 30.0, NEWTONS
            )
            self.dither_torque_threshold = TypedNumber(
                gui, "dither-torque-threshold", "Dither torque limit [N m]", 3.0, NEWTON_METRES
            )
            self.dither_monitor = gui.add_checkbox("Dither force task monitor", False, hint=MONITOR_HINT)
            self.dither_check = add_html(gui, _check_html("dither", "", []))
            self.send_dither = gui.add_button("Send dither", color="blue", disabled=True)
            self.dither_preset.on_update(lambda _: self.fill_dither_fields())
            self.dither_mode.on_update(lambda _: self._label_amplitude())
            self.fill_dither_fields()
        with tabs.add_tab("Frames"):  # task frames: named axes to command in (robot_sim/task_frames.py)
            self.frames_list = add_html(gui, frames_html([]))
            self.new_frame_name = gui.add_text("New frame name", "frame1", hint=FRAME_NAME_HINT)
            self.add_frame_at_tool = gui.add_button(
                "Add at tool pose",
                color="teal",
                disabled=True,
                hint="the port's pose as the robot has it now",
            )
            self.new_frame_position = TypedVector(
                gui, "frame-origin", "Typed origin [mm]", (400.0, 0.0, 300.0), MM
            )
            self.new_frame_rotation = TypedVector(
                gui,
                "frame-rotation",
                "Typed rotation [deg]",
                (0.0, 0.0, 0.0),
                DEG,
                hint="rotation vector from base axes",
            )
            self.add_frame_typed = gui.add_button("Add typed pose", color="teal", disabled=True)
            self.delete_frame_name = gui.add_dropdown("Delete frame", ("(none)",), initial_value="(none)")
            self.delete_frame = gui.add_button("Delete", color="red", disabled=True)
            self.show_frames = gui.add_checkbox("Show frames in 3D", True)
        with tabs.add_tab("Tasks"):  # a task's onboard state machine, run as one command
            names = list(tasks) or ["(none)"]
            self.task = gui.add_dropdown("Task", names, initial_value=names[0])
            self.task_summary = add_html(gui, _summary_html(tasks.get(names[0], "")))
            self.task_check = add_html(gui, _check_html("state_machine", "", []))
            self.send_task = gui.add_button(
                "Run state machine", color="blue", disabled=True, hint="STOP aborts it like any command"
            )
            self.task.on_update(lambda _: self._show_task())
            # The tool tasks' gripper (paper 2.3.3-2.3.4): refused on a scene whose tool has none.
            self.gripper_action = gui.add_dropdown("Gripper", ("close", "open"), initial_value="close")
            self.gripper_check = add_html(gui, _check_html("gripper", "", []))
            self.send_gripper = gui.add_button("Send gripper", color="blue", disabled=True)

        initial = defaults.stiffness_preset if defaults.stiffness_preset in stiffness_presets else None
        self.stiffness = gui.add_dropdown(
            "Stiffness preset (PTWL)",
            list(stiffness_presets),
            initial_value=initial or next(iter(stiffness_presets)),
            order=FORM_ORDER + 0.3,
        )
        self.stiffness_info = add_html(gui, self._stiffness_html(), order=FORM_ORDER + 0.4)
        self.stiffness.on_update(lambda _: self._show_stiffness())
        # Per request type, in one place: its Send button, its check line, how it is made, the
        # inputs it is made from.
        self.sends = {
            "ptwl": self.send_ptwl,
            "rwe": self.send_rwe,
            "dither": self.send_dither,
            "state_machine": self.send_task,
            "gripper": self.send_gripper,
        }
        self._checks = {
            "ptwl": self.ptwl_check,
            "rwe": self.rwe_check,
            "dither": self.dither_check,
            "state_machine": self.task_check,
            "gripper": self.gripper_check,
        }
        self._makers = {
            "ptwl": self.ptwl_params,
            "rwe": self.rwe_params,
            "dither": self.dither_params,
            "state_machine": self.task_params,
            "gripper": self.gripper_params,
        }
        self._fields: dict[str, list[Any]] = {
            "ptwl": [
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
                self.stiffness,
                self.gains_frame,
                self.monitor,
            ],
            "rwe": [*self.rwe_axes.values(), self.rwe_duration, self.rwe_frame],
            "dither": [
                self.dither_preset,
                self.dither_mode,
                self.dither_direction,
                self.dither_axis,
                self.dither_frame,
                self.dither_amplitude,
                self.dither_frequency,
                self.dither_travel,
                self.dither_duration,
                self.dither_force_threshold,
                self.dither_torque_threshold,
                self.dither_monitor,
            ],
            "state_machine": [self.task],
            "gripper": [self.gripper_action],
        }
        # The number fields each request is made from, by the API's name for them: where the
        # robot's rules' refusals of a request are said.
        self._typed: dict[str, dict[str, TypedNumber | TypedVector]] = {
            "ptwl": {
                "translation": self.translation,
                "rotation": self.rotation,
                "duration": self.duration,
                "force_threshold": self.force_threshold,
                "torque_threshold": self.torque_threshold,
                "position_tolerance": self.position_tolerance,
                "orientation_tolerance": self.orientation_tolerance,
                "watchdog": self.watchdog,
            },
            "rwe": {"duration": self.rwe_duration},
            "dither": {
                "axis": self.dither_axis,
                "amplitude": self.dither_amplitude,
                "frequency": self.dither_frequency,
                "travel": self.dither_travel,
                "duration": self.dither_duration,
                "force_threshold": self.dither_force_threshold,
                "torque_threshold": self.dither_torque_threshold,
            },
            "state_machine": {},
            "gripper": {},
        }
        self._valid = dict.fromkeys(self.sends, True)
        self._contemplated = contemplated_html(None, "no robot state yet")
        self.step_percent.on_update(lambda _: self._check_step())
        self.new_frame_position.on_update(lambda _: self._typed_pose_changed())
        self.new_frame_rotation.on_update(lambda _: self._typed_pose_changed())

    @property
    def send_buttons(self) -> tuple[Any, ...]:
        return tuple(self.sends.values())

    def params(self, behavior: str) -> dict[str, Any]:
        """The request `behavior`'s tab makes from its fields."""
        return self._makers[behavior]()

    def fields(self, behavior: str) -> list[Any]:
        """The inputs whose values make up a behavior's request."""
        return self._fields[behavior]

    def show_control(self, mine: bool, holder: str | None) -> None:
        """Enable sending only for the client that holds control; say who does."""
        self._mine = mine
        self.refresh_buttons()
        self.take_control.visible = not mine
        show(self.control, _control_html(mine, holder))

    def _in_use(self, behavior: str) -> dict[str, TypedNumber | TypedVector]:
        """The number fields the request is made from now (the watchdog only when typed)."""
        fields = self._typed[behavior]
        if behavior == "ptwl" and self.watchdog_auto.value:
            return {name: typed for name, typed in fields.items() if name != "watchdog"}
        return fields

    def show_check(self, behavior: str, check: Check) -> None:
        """What the robot's own rules say of the request as typed: each refusal at its field, in
        its units, and all of them on the check line; Send is off while it is refused."""
        fields = self._in_use(behavior)
        for typed in fields.values():
            typed.clear()
        said = []
        for item in check.by_field:
            at = fields.get(_field_named(item, fields))
            if at is None:
                said.append(f"{item['field']}: {item['message']}")
                continue
            refusal = at.refuse(item["message"])
            named = "" if item["field"] == "body" else f"{item['field']}: "  # the message names it
            said.append(named + refusal)
        errors = "; ".join(said) or check.errors
        self._valid[behavior] = not errors
        self._show_reasons(behavior)
        show(self._checks[behavior], _check_html(behavior, errors, check.warnings))
        watchdog_s = getattr(check.params, "watchdog", None)
        if behavior == "ptwl" and watchdog_s is not None and self.watchdog_auto.value:
            self.watchdog.value = round(watchdog_s, 3)
        self.refresh_buttons()

    def show_unreadable(self, behavior: str) -> None:
        """A field's text is not a number: nothing is checked or sent until it is; each such
        field says why, and the check line names them."""
        fields = self._in_use(behavior)
        for typed in fields.values():
            typed.clear()  # judged on other text: the robot's words wait for a request to judge
        self._valid[behavior] = False
        self._show_reasons(behavior)
        wrong = "; ".join(f"{t.label}: {t.reason}" for t in fields.values() if t.reason)
        show(self._checks[behavior], _check_html(behavior, "", [], unreadable=wrong))
        self.refresh_buttons()

    def _show_reasons(self, behavior: str) -> None:
        in_use = self._in_use(behavior)
        for typed in self._typed[behavior].values():
            typed.show(active=typed in in_use.values())
        self.watchdog.disabled = bool(self.watchdog_auto.value)

    def show_contemplated(self, distance_mm: float | None, why_not: str) -> None:
        """The contemplated target as the 3D view draws it, in words: how far from the port, or
        why none is drawn (sent only when it changed: this follows every telemetry state)."""
        shown = contemplated_html(distance_mm, why_not)
        if shown != self._contemplated:
            self._contemplated = shown
            show(self.contemplated_line, shown)

    def _check_step(self) -> None:
        self.step_percent.clear()
        try:
            if not 0.0 < self.step_percent.value <= 100.0:
                self.step_percent.refuse(f"{STEP_RANGE}, got {self.step_percent.value:g}")
        except FieldError:
            pass  # its reason is its text's
        self.step_percent.show()
        self.refresh_buttons()

    def _typed_pose_changed(self) -> None:
        self.new_frame_position.show()
        self.new_frame_rotation.show()
        self.refresh_buttons()

    def refresh_buttons(self) -> None:
        for behavior, button in self.sends.items():
            button.disabled = not (self._mine and self._valid[behavior])
        # The same PTWL, a part of it; its preview runs what Send would send.
        self.send_step.disabled = self.send_ptwl.disabled or bool(self.step_percent.reason)
        self.preview.disabled = not self._valid["ptwl"]
        # Frames change what commands mean: only the operator in control adds or deletes them.
        self.add_frame_at_tool.disabled = not self._mine
        typed_pose = (self.new_frame_position, self.new_frame_rotation)
        self.add_frame_typed.disabled = not self._mine or any(t.reason for t in typed_pose)
        self.delete_frame.disabled = not self._mine or self.delete_frame_name.value == "(none)"

    def show_frames_known(self, frames: list[dict[str, Any]]) -> None:
        """The robot's task frames: listed, offered in every frame field, deletable if an operator's."""
        names = list(dict.fromkeys([*BUILT_IN_FRAMES, *(f["name"] for f in frames)]))  # Mantine: no repeats
        for field in (self.frame, self.rwe_frame, self.dither_frame):
            field.options = names  # viser keeps the value if it is still there, else takes the first
        self.gains_frame.options = [PRESET_FRAME, *names]
        deletable = [f["name"] for f in frames if f["source"] == "operator"] or ["(none)"]
        self.delete_frame_name.options = deletable
        show(self.frames_list, frames_html(frames))
        self.refresh_buttons()

    def typed_frame_pose(self) -> dict[str, list[float]]:
        """The typed pose in the API's units: origin [m], axes as a quaternion from the rotation
        vector; FieldError if either is not three numbers."""
        quaternion = np.array([1.0, 0.0, 0.0, 0.0])
        mujoco.mju_quatIntegrate(quaternion, np.asarray(self.new_frame_rotation.si, dtype=float), 1.0)
        return {"position": self.new_frame_position.si, "quaternion": quaternion.tolist()}

    def _stiffness_html(self) -> Markup:
        preset = self.stiffness_presets[str(self.stiffness.value)]
        return gains_html(
            preset["stiffness"], preset["damping"], "ptwl-preset", preset.get("description", "")
        )

    def _show_stiffness(self) -> None:
        show(self.stiffness_info, self._stiffness_html())

    def show_scene_task(self, scene: str) -> None:
        """Pick the loaded scene's task (each task's machine runs only on its own scene)."""
        if scene in self.tasks and self.task.value != scene:
            _set(self.task, scene)
            self._show_task()

    def _show_task(self) -> None:
        show(self.task_summary, _summary_html(self.tasks.get(str(self.task.value), "")))

    def _label_amplitude(self) -> None:
        mode = str(self.dither_mode.value)
        self.dither_amplitude.relabel(AMPLITUDE_LABELS[mode], AMPLITUDE_UNITS[mode])

    # ------------------------------------------------------------ requests
    def ptwl_values(self) -> tuple[np.ndarray, np.ndarray, str]:
        """(translation [m], rotation vector [rad], frame) where the contemplated target is drawn;
        FieldError while either is not numbers, or is what the robot's rules refuse (no target
        is shown for a move that will not be sent)."""
        for typed in (self.translation, self.rotation):
            if typed.reason:
                raise FieldError(f"{typed.label} is marked in red")
        return np.asarray(self.translation.si), np.asarray(self.rotation.si), str(self.frame.value)

    def ptwl_params(self) -> dict[str, Any]:
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
            "preset": str(self.stiffness.value),
            **(
                {} if self.gains_frame.value == PRESET_FRAME else {"gains_frame": str(self.gains_frame.value)}
            ),
            **({"monitor": {}} if self.monitor.value else {}),  # the robot's default settings
        }

    def step_params(self) -> dict[str, Any]:
        """The first part of the PTWL (IPSE's step): displacement and duration scaled alike, so the
        attractor walks the first stretch of the same path at the same speed."""
        params = self.ptwl_params()
        if self.step_percent.reason:
            raise FieldError(f"{self.step_percent.label}: {self.step_percent.reason}")
        part = self.step_percent.value / 100.0
        params["translation"] = [part * v for v in params["translation"]]
        params["rotation"] = [part * v for v in params["rotation"]]
        params["duration"] *= part
        return params

    def set_ptwl_displacement(self, translation_m: np.ndarray, rotation_rad: np.ndarray) -> None:
        """Written as text to 0.01 mm and deg: what the fields then show is what is sent."""
        self.translation.value = [round(v * MM.per_si, 2) for v in np.asarray(translation_m, dtype=float)]
        self.rotation.value = [round(v * DEG.per_si, 2) for v in np.asarray(rotation_rad, dtype=float)]

    def task_params(self) -> dict[str, Any]:
        return {"task": str(self.task.value)}

    def gripper_params(self) -> dict[str, Any]:
        return {"action": str(self.gripper_action.value)}

    def rwe_params(self) -> dict[str, Any]:
        return {
            "axes": [a for a, box in self.rwe_axes.items() if box.value],
            "duration": self.rwe_duration.si,
            "frame": str(self.rwe_frame.value),
        }

    def fill_dither_fields(self) -> None:
        """Every field of the chosen preset, in the units of its mode."""
        p = self.dither_presets[str(self.dither_preset.value)]
        _set(self.dither_mode, p["mode"])
        _set(self.dither_direction, p["direction"])
        self._label_amplitude()
        self.dither_axis.value = [float(v) for v in p["axis"]]
        self.dither_amplitude.value = p["amplitude"] * self.dither_amplitude.unit.per_si
        self.dither_frequency.value = p["frequency"]
        self.dither_travel.value = p["travel"] * MM.per_si
        self.dither_duration.value = p["duration"]
        self.dither_force_threshold.value = p["force_threshold"]
        self.dither_torque_threshold.value = p["torque_threshold"]

    def dither_params(self) -> dict[str, Any]:
        """Every field explicit (the preset's name is not sent: what is shown is what runs);
        FieldError while a field's text is not a number."""
        return {
            "mode": str(self.dither_mode.value),
            "direction": str(self.dither_direction.value),
            "axis": self.dither_axis.si,
            "frame": str(self.dither_frame.value),
            "amplitude": self.dither_amplitude.si,
            "frequency": self.dither_frequency.si,
            "travel": self.dither_travel.si,
            "duration": self.dither_duration.si,
            "force_threshold": self.dither_force_threshold.si,
            "torque_threshold": self.dither_torque_threshold.si,
            **({"monitor": {}} if self.dither_monitor.value else {}),
        }


def _set(handle: Any, value: Any) -> None:
    """Assign a GUI input's value (a per-client handle: only this browser sees it)."""
    handle.value = value


def _control_html(mine: bool, holder: str | None) -> Markup:
    if mine:
        text, color = Markup("You have control: your commands go to the robot."), "#2f9e44"
    elif holder:
        text = Markup("Watching: <b>{}</b> has control. Your fields are your own.").format(holder)
        color = "#868e96"
    else:
        text, color = Markup("Watching: nobody has control. Take it to send."), "#868e96"
    return Markup(
        '<div id="ptwl-control" data-mine="{}" data-holder="{}" '
        'style="padding:4px 8px;border-left:6px solid {}">{}</div>'
    ).format(int(mine), holder or "", color, text)


def gains_html(stiffness: list[float], damping: list[float], element_id: str, title: str = "") -> Markup:
    """K, B and the time constant tau = B/K per axis group (translation, rotation)."""
    k, b = np.asarray(stiffness, dtype=float), np.asarray(damping, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        tau = np.where(k > 0, b / k, np.inf)

    def row(name: str, sl: slice, k_unit: str, b_unit: str) -> str:
        ks = ", ".join(f"{v:g}" for v in k[sl])
        bs = ", ".join(f"{v:g}" for v in b[sl])
        taus = ", ".join("∞" if not np.isfinite(v) else f"{v:.2f}" for v in tau[sl])
        return f"{name}: K ({ks}) {k_unit} · B ({bs}) {b_unit} · τ ({taus}) s"

    return Markup(
        '<div id="{}" data-k="{}" data-b="{}" title="{}" style="font-size:0.8em;color:#495057;padding:0 4px">'
        "{}<br>{}</div>"
    ).format(
        element_id,
        ",".join(f"{v:g}" for v in k),
        ",".join(f"{v:g}" for v in b),
        title,
        row("translation", slice(0, 3), "N/m", "N s/m"),
        row("rotation", slice(3, 6), "N m/rad", "N m s/rad"),
    )


def _summary_html(summary: str) -> Markup:
    return Markup('<div style="font-size:0.85em;padding:0 4px">{}</div>').format(summary)


def _field_named(item: dict[str, Any], fields: dict[str, Any]) -> str:
    """The request field an API error item is about: `translation` for `translation[1]`; for a
    rule across fields (`body`), the field its message starts with ("watchdog (3 s) must ...")."""
    name = re.split(r"[\[.]", str(item["field"]), maxsplit=1)[0]
    if name == "body":
        name = str(item["message"]).split(" ", 1)[0]
    return name if name in fields else ""


def _check_html(behavior: str, errors: str, warnings: list[str], unreadable: str = "") -> Markup:
    if unreadable:  # not judged by the robot's rules at all: there is no request yet
        body, color = f"not sent until fixed: {unreadable}", "#e03131"
    elif errors:
        body, color = f"will be refused: {errors}", "#e03131"
    elif warnings:
        body, color = "accepted, but: " + " ".join(warnings), "#e8590c"
    else:
        body, color = "within the robot's limits", "#868e96"
    return Markup(
        '<div id="ptwl-check-{}" data-valid="{}" data-readable="{}" data-warnings="{}" '
        'style="font-size:0.8em;color:{};padding:0 4px">{}</div>'
    ).format(behavior, int(not (errors or unreadable)), int(not unreadable), len(warnings), color, body)


def contemplated_html(distance_mm: float | None, why_not: str = "") -> Markup:
    """The contemplated target in words, as the 3D view draws it (the DOM can read this line; the
    WebGL view it mirrors it cannot)."""
    if distance_mm is None:
        return Markup(
            '<div id="ptwl-contemplated" data-shown="0" data-distance="" '
            'style="font-size:0.8em;color:#868e96;padding:0 4px">no target drawn: {}</div>'
        ).format(why_not)
    return Markup(
        '<div id="ptwl-contemplated" data-shown="1" data-distance="{:.1f}" '
        'style="font-size:0.8em;color:#868e96;padding:0 4px">target {:.1f} mm from the port</div>'
    ).format(distance_mm, distance_mm)


def frames_html(frames: list[dict[str, Any]]) -> Markup:
    """The task frames the robot has, each with its pose in base axes (origin, and rotation as the
    typed rotation reads it: a rotation vector) and where it came from."""
    row = Markup(
        "<li><b>{}</b> origin ({:.1f}, {:.1f}, {:.1f}) mm, rotation ({:.1f}, {:.1f}, {:.1f}) deg "
        "<span style='color:#868e96'>({}: {})</span></li>"
    )
    rows = Markup("").join(
        row.format(f["name"], *_origin_mm(f), *_rotation_deg(f), f["source"], f["defined_by"]) for f in frames
    )
    body = (
        Markup("<ul style='margin:0;padding-left:16px'>{}</ul>").format(rows)
        if frames
        else "only tool and base"
    )
    return Markup('<div id="ptwl-frames" data-names="{}" style="font-size:0.85em">{}</div>').format(
        ",".join(f["name"] for f in frames), body
    )


def _origin_mm(frame: dict[str, Any]) -> list[float]:
    return [1000.0 * v for v in frame["pose"]["position"]]


def _rotation_deg(frame: dict[str, Any]) -> list[float]:
    return np.degrees(tf.SO3(np.asarray(frame["pose"]["quaternion"], dtype=float)).log()).tolist()


def preview_html(result: Any, note: str = "", state: str = "") -> Markup:
    """What the preview says (a PreviewResult, with `note` on where it started; None: `note`, why
    there is none): exit, when, peak; `state` "computing" (since `note`) or "stale" (the fields
    changed since it ran: it is not what Send would do now)."""
    if state == "computing":
        return Markup(
            '<div id="ptwl-preview" data-exit="" data-state="computing" '
            'style="color:#1971c2;font-size:0.85em">preview: computing (since {})…</div>'
        ).format(note)
    if result is None:
        return Markup(
            '<div id="ptwl-preview" data-exit="" data-state="" '
            'style="color:#868e96;font-size:0.85em">{}</div>'
        ).format(note or "no preview yet")
    stale = (
        Markup(' <b style="color:#e8590c">STALE: the fields changed since; preview again</b>')
        if state == "stale"
        else ""
    )
    return Markup(
        '<div id="ptwl-preview" data-exit="{exit}" data-state="{state}" data-duration="{duration:.3f}" '
        'data-peak-force="{force:.3f}" data-compute-s="{compute:.3f}" style="font-size:0.85em;{faded}">'
        "preview: <b>{exit}</b> after {duration:.2f} s, peak {force:.1f} N / {torque:.2f} N m "
        '<span style="color:#868e96">(computed in {compute:.2f} s{started})</span>{stale}</div>'
    ).format(
        exit=result.exit,
        state=state,
        duration=result.duration_s,
        force=result.peak_force_n,
        torque=result.peak_torque_nm,
        compute=result.compute_s,
        started=f"; {note}" if note else "",
        faded="opacity:0.6" if state == "stale" else "",
        stale=stale,
    )
