"""The control panel of the paper's Fig. 2: PTWL, RWE and Dither tabs over a stiffness preset.

Fields are in operator units (mm, deg); `ptwl_params()` and friends turn them into the API's SI
request bodies. The panel only builds widgets and reads them; what a click does is wired by the
app, which keeps this file free of robot and link logic.
"""

import math
from typing import Any

import mujoco
import numpy as np
import viser

from web.defaults import ConsoleDefaults
from web.markup import Markup, add_html, show

AXES = ("x", "y", "z", "rx", "ry", "rz")
AMPLITUDE_LABELS = {"torsional": "Amplitude [deg]", "translational": "Amplitude (radius) [mm]"}
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
            self.translation = gui.add_vector3("Translation [mm]", tuple(d["translation_mm"]), step=0.1)
            self.rotation = gui.add_vector3("Rotation [deg]", tuple(d["rotation_deg"]), step=0.1)
            self.frame = gui.add_dropdown("Frame", BUILT_IN_FRAMES, initial_value=d["frame"], hint=FRAME_HINT)
            self.duration = gui.add_number("Duration [s]", d["duration_s"], min=0.01, max=600.0, step=0.1)
            self.force_threshold = gui.add_number(
                "Force threshold [N]", d["force_threshold_n"], min=0.1, step=0.5
            )
            self.torque_threshold = gui.add_number(
                "Torque threshold [N m]", d["torque_threshold_nm"], min=0.01, step=0.05
            )
            self.show_gizmo = gui.add_checkbox("Drag target in 3D", False)
            # What is set once and left: folded away, so Send, Preview and Step stay in view.
            with gui.add_folder("Tolerances, watchdog, gains frame", expand_by_default=False):
                self.position_tolerance = gui.add_number(
                    "Position tolerance [mm]", d["position_tolerance_mm"], min=0.01, step=0.1
                )
                self.orientation_tolerance = gui.add_number(
                    "Orientation tolerance [deg]", d["orientation_tolerance_deg"], min=0.01, step=0.1
                )
                self.watchdog_auto = gui.add_checkbox(
                    "Watchdog follows duration",
                    True,
                    hint="the robot's default: duration + 5 s; untick to set it",
                )
                self.watchdog = gui.add_number(
                    "Watchdog [s]", d["duration_s"] + 5.0, min=0.01, max=600.0, step=0.5, disabled=True
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
            self.step_percent = gui.add_number("Step [% of the move]", 25.0, min=1.0, max=100.0, step=5.0)
            self.send_step = gui.add_button("Send step", color="cyan", disabled=True, hint=STEP_HINT)
        with tabs.add_tab("RWE"), gui.add_form(None) as self.forms["rwe"]:
            self.rwe_axes = {a: gui.add_checkbox(a, a in defaults.rwe["axes"]) for a in AXES}
            self.rwe_duration = gui.add_number(
                "RWE duration [s]", defaults.rwe["duration_s"], min=0.01, max=600.0
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
            self.dither_axis = gui.add_vector3("Axis", (0.0, 0.0, 1.0), step=0.1)
            self.dither_frame = gui.add_dropdown(
                "Axis frame", BUILT_IN_FRAMES, initial_value="tool", hint=FRAME_HINT
            )
            self.dither_amplitude = gui.add_number(AMPLITUDE_LABELS["torsional"], 1.0, min=0.001, step=0.1)
            self.dither_frequency = gui.add_number("Frequency [Hz]", 1.0, min=0.01, max=10.0, step=0.1)
            self.dither_travel = gui.add_number("Travel [mm]", 10.0, min=0.0, max=1000.0, step=0.5)
            self.dither_duration = gui.add_number("Dither duration [s]", 5.0, min=0.01, max=600.0, step=0.5)
            self.dither_force_threshold = gui.add_number("Dither force limit [N]", 30.0, min=0.1, step=0.5)
            self.dither_torque_threshold = gui.add_number(
                "Dither torque limit [N m]", 3.0, min=0.01, step=0.05
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
            self.new_frame_position = gui.add_vector3("Typed origin [mm]", (400.0, 0.0, 300.0), step=1.0)
            self.new_frame_rotation = gui.add_vector3(
                "Typed rotation [deg]", (0.0, 0.0, 0.0), step=1.0, hint="rotation vector from base axes"
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
        self._valid = dict.fromkeys(self.sends, True)

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

    def show_check(self, behavior: str, errors: str, warnings: list[str], watchdog_s: float | None) -> None:
        """What the robot's own rules say of the request as typed; Send is off while it is invalid."""
        self._valid[behavior] = not errors
        show(self._checks[behavior], _check_html(behavior, errors, warnings))
        if behavior == "ptwl" and watchdog_s is not None and self.watchdog_auto.value:
            _set(self.watchdog, round(watchdog_s, 3))
        self.watchdog.disabled = bool(self.watchdog_auto.value)
        self.refresh_buttons()

    def refresh_buttons(self) -> None:
        for behavior, button in self.sends.items():
            button.disabled = not (self._mine and self._valid[behavior])
        self.send_step.disabled = self.send_ptwl.disabled  # the same PTWL, a part of it
        # Frames change what commands mean: only the operator in control adds or deletes them.
        self.add_frame_at_tool.disabled = self.add_frame_typed.disabled = not self._mine
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
        """The typed pose in the API's units: origin [m], axes as a quaternion from the rotation vector."""
        quaternion = np.array([1.0, 0.0, 0.0, 0.0])
        mujoco.mju_quatIntegrate(
            quaternion, np.radians(np.asarray(self.new_frame_rotation.value, dtype=float)), 1.0
        )
        position = np.asarray(self.new_frame_position.value, dtype=float) / 1000.0
        return {"position": position.tolist(), "quaternion": quaternion.tolist()}

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
        self.dither_amplitude.label = AMPLITUDE_LABELS[str(self.dither_mode.value)]

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
            **({} if self.watchdog_auto.value else {"watchdog": float(self.watchdog.value)}),
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
        part = float(self.step_percent.value) / 100.0
        params["translation"] = [part * v for v in params["translation"]]
        params["rotation"] = [part * v for v in params["rotation"]]
        params["duration"] *= part
        return params

    def set_ptwl_displacement(self, translation_m: np.ndarray, rotation_rad: np.ndarray) -> None:
        _set(self.translation, np.round(np.asarray(translation_m) * 1000.0, 2))
        _set(self.rotation, np.round(np.degrees(rotation_rad), 2))

    def task_params(self) -> dict[str, Any]:
        return {"task": str(self.task.value)}

    def gripper_params(self) -> dict[str, Any]:
        return {"action": str(self.gripper_action.value)}

    def rwe_params(self) -> dict[str, Any]:
        return {
            "axes": [a for a, box in self.rwe_axes.items() if box.value],
            "duration": float(self.rwe_duration.value),
            "frame": str(self.rwe_frame.value),
        }

    def fill_dither_fields(self) -> None:
        """Every field of the chosen preset, in the units of its mode."""
        p = self.dither_presets[str(self.dither_preset.value)]
        _set(self.dither_mode, p["mode"])
        _set(self.dither_direction, p["direction"])
        self._label_amplitude()
        _set(self.dither_axis, np.asarray(p["axis"], dtype=float))
        torsional = p["mode"] == "torsional"
        _set(
            self.dither_amplitude,
            round(math.degrees(p["amplitude"]) if torsional else p["amplitude"] * 1000, 3),
        )
        _set(self.dither_frequency, p["frequency"])
        _set(self.dither_travel, round(p["travel"] * 1000.0, 3))
        _set(self.dither_duration, p["duration"])
        _set(self.dither_force_threshold, p["force_threshold"])
        _set(self.dither_torque_threshold, p["torque_threshold"])

    def dither_params(self) -> dict[str, Any]:
        """Every field explicit (the preset's name is not sent: what is shown is what runs)."""
        amplitude = float(self.dither_amplitude.value)
        torsional = self.dither_mode.value == "torsional"
        return {
            "mode": str(self.dither_mode.value),
            "direction": str(self.dither_direction.value),
            "axis": list(self.dither_axis.value),
            "frame": str(self.dither_frame.value),
            "amplitude": math.radians(amplitude) if torsional else amplitude / 1000.0,
            "frequency": float(self.dither_frequency.value),
            "travel": float(self.dither_travel.value) / 1000.0,
            "duration": float(self.dither_duration.value),
            "force_threshold": float(self.dither_force_threshold.value),
            "torque_threshold": float(self.dither_torque_threshold.value),
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


def _check_html(behavior: str, errors: str, warnings: list[str]) -> Markup:
    if errors:
        body, color = f"will be refused: {errors}", "#e03131"
    elif warnings:
        body, color = "accepted, but: " + " ".join(warnings), "#e8590c"
    else:
        body, color = "within the robot's limits", "#868e96"
    return Markup(
        '<div id="ptwl-check-{}" data-valid="{}" data-warnings="{}" '
        'style="font-size:0.8em;color:{};padding:0 4px">{}</div>'
    ).format(behavior, int(not errors), len(warnings), color, body)


def frames_html(frames: list[dict[str, Any]]) -> Markup:
    """The task frames the robot has, each with where it came from."""
    row = Markup("<li><b>{}</b> ({}: {})</li>")
    rows = Markup("").join(row.format(f["name"], f["source"], f["defined_by"]) for f in frames)
    body = (
        Markup("<ul style='margin:0;padding-left:16px'>{}</ul>").format(rows)
        if frames
        else "only tool and base"
    )
    return Markup('<div id="ptwl-frames" data-names="{}" style="font-size:0.85em">{}</div>').format(
        ",".join(f["name"] for f in frames), body
    )


def preview_html(result: Any, note: str = "") -> Markup:
    """What the preview says (a PreviewResult, with `note` on where it started; None: `note`, why
    there is none): exit, when, peak."""
    if result is None:
        return Markup(
            '<div id="ptwl-preview" data-exit="" style="color:#868e96;font-size:0.85em">{}</div>'
        ).format(note or "no preview yet")
    return Markup(
        '<div id="ptwl-preview" data-exit="{exit}" data-duration="{duration:.3f}" '
        'data-peak-force="{force:.3f}" data-compute-s="{compute:.3f}" style="font-size:0.85em">'
        "preview: <b>{exit}</b> after {duration:.2f} s, peak {force:.1f} N / {torque:.2f} N m "
        '<span style="color:#868e96">(computed in {compute:.2f} s{started})</span></div>'
    ).format(
        exit=result.exit,
        duration=result.duration_s,
        force=result.peak_force_n,
        torque=result.peak_torque_nm,
        compute=result.compute_s,
        started=f"; {note}" if note else "",
    )
