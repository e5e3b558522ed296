"""One browser's desk: its own form, its own contemplated target and gizmo, and its place in the
control seat. What it sends goes through the console's shared `send` (one path for every desk),
and only what its fields show: a field whose text is not a number (FieldError) sends nothing,
previews nothing and draws no target."""

from collections.abc import Callable
from typing import Any

import numpy as np
import viser

from robot_sim.errors import UnknownNameError
from robot_sim.task_frames import TaskFrames
from web.checks import Check
from web.defaults import ConsoleDefaults
from web.frames_view import FramesView
from web.label_places import CONTEMPLATED
from web.markers import TargetMarker
from web.markup import show
from web.panel import Panel, preview_html
from web.preview import PreviewResult
from web.preview_marks import PreviewMarks
from web.seat import ControlSeat, operator_name
from web.targets import Pose, displacement_to, ptwl_target
from web.typed_number import FieldError

YELLOW = (250, 204, 21)
SendFn = Callable[["Desk", str, dict[str, Any]], None]
PreviewFn = Callable[["Desk"], None]
CheckFn = Callable[[str, dict[str, Any]], Check]
FramesFn = Callable[[], TaskFrames]
FrameEditFn = Callable[["Desk", str, "dict[str, list[float]] | str | None"], None]


class Desk:
    def __init__(
        self,
        client: viser.ClientHandle,
        defaults: ConsoleDefaults,
        stiffness_presets: dict[str, dict[str, Any]],
        dither_presets: dict[str, dict[str, Any]],
        tasks: dict[str, str],
        seat: ControlSeat,
        port: Callable[[], Pose | None],
        send: SendFn,
        check: CheckFn,
        preview: PreviewFn,
        frames: FramesFn,
        edit_frame: FrameEditFn,
    ) -> None:
        self.client = client
        self.name = operator_name(client.client_id) or ""
        self._seat = seat
        self._port = port
        self._frames = frames
        self._syncing_gizmo = False
        self.panel = Panel(client.gui, defaults, stiffness_presets, dither_presets, tasks)
        scene = client.scene
        self.contemplated = TargetMarker(
            scene,
            "contemplated",
            "contemplated",
            YELLOW,
            CONTEMPLATED,
            distance_anchor="top-right",  # the commanded line's length is written bottom-left
        )
        self.gizmo = scene.add_transform_controls("/gizmo", scale=0.08, visible=False)
        self.preview_marks = PreviewMarks(scene)
        self.frames_view = FramesView(scene)
        panel = self.panel
        # Frames: add at the tool or a typed pose (the name typed), delete one (None: no pose).
        panel.add_frame_at_tool.on_click(lambda _: edit_frame(self, str(panel.new_frame_name.value), "tool"))
        panel.add_frame_typed.on_click(lambda _: self._add_typed_frame(edit_frame))
        panel.delete_frame.on_click(lambda _: edit_frame(self, str(panel.delete_frame_name.value), None))
        panel.delete_frame_name.on_update(lambda _: panel.refresh_buttons())
        panel.show_frames.on_update(lambda _: self.frames_view.set_visible(bool(panel.show_frames.value)))
        panel.take_control.on_click(lambda _: seat.take(client.client_id))
        for behavior, button in panel.sends.items():
            button.on_click(self._sender(send, behavior))
        panel.send_step.on_click(lambda _: self._send_typed(send, "ptwl", panel.step_params))
        panel.preview.on_click(lambda _: self._preview(preview))
        for behavior, form in panel.forms.items():  # Enter in one of the tab's fields
            form.on_submit(self._key_sender(send, behavior))
        # The target follows the PTWL's fields through its check (recheck), which first says
        # whether the robot's rules take them; the gizmo's box has no rule.
        panel.show_gizmo.on_update(lambda _: self.fields_changed())
        for behavior in panel.sends:
            for field in panel.fields(behavior):
                field.on_update(lambda _, b=behavior: self.recheck(b))
        self.gizmo.on_update(lambda _: self._gizmo_moved())
        # Page keys (viser's command palette hotkeys, which act once the focus has left a text
        # field, e.g. after dragging the target in 3D): Enter sends the PTWL as Send would, Escape
        # clears the contemplated target back to "no move".
        send_key = client.gui.add_command("Send PTWL", description="as the Send cmd button", hotkey="enter")
        send_key.on_trigger(self._key_sender(send, "ptwl"))
        clear_key = client.gui.add_command(
            "Clear target", description="translation and rotation to 0", hotkey="escape"
        )
        clear_key.on_trigger(lambda _: self.clear_contemplated())
        self._check = check
        self.seat_changed()
        for behavior in self.panel.sends:
            self.recheck(behavior)

    @property
    def client_id(self) -> int:
        return self.client.client_id

    def _key_sender(self, send: SendFn, behavior: str) -> Callable[[Any], None]:
        """A key's send: only what the tab's button would send now (in control, valid)."""

        def send_if_enabled(_: Any) -> None:
            if not self.panel.sends[behavior].disabled:
                self._send_typed(send, behavior, lambda: self.params(behavior))

        return send_if_enabled

    def _send_typed(self, send: SendFn, behavior: str, make: Callable[[], dict[str, Any]]) -> None:
        """Send what `make` reads from the fields, unless a field's text is not a number (its
        button is off then; this holds a click or key that came before the button turned off)."""
        try:
            params = make()
        except FieldError as err:
            self.client.add_notification("Not sent: a field is marked in red", err.reason, color="red")
            return
        send(self, behavior, params)

    def _preview(self, preview: PreviewFn) -> None:
        try:
            self.params("ptwl")
        except FieldError as err:
            self.show_preview(None, f"no preview: {err.reason}")
            return
        preview(self)

    def _add_typed_frame(self, edit_frame: FrameEditFn) -> None:
        try:
            pose = self.panel.typed_frame_pose()
        except FieldError as err:
            self.client.add_notification("Frame not added: a field is marked in red", err.reason, color="red")
            return
        edit_frame(self, str(self.panel.new_frame_name.value), pose)

    def show_preview(self, result: PreviewResult | None, note: str = "") -> None:
        """A preview's paths and exit in this browser only, with `note` (where it started from);
        None: why there is none (`note`)."""
        if result is None:
            self.preview_marks.hide()
        else:
            self.preview_marks.show(result)
        show(self.panel.preview_html, preview_html(result, note))

    def clear_contemplated(self) -> None:
        self.panel.set_ptwl_displacement(np.zeros(3), np.zeros(3))
        self.fields_changed()
        self.recheck("ptwl")

    def seat_changed(self) -> None:
        holder = self._seat.holder
        self.panel.show_control(holder == self.client_id, operator_name(holder))

    def show_frames(self, frames: list[dict[str, Any]]) -> None:
        """The robot's task frames changed (or first became known): offer them, draw them, and
        check the requests again (a frame a field names may be gone)."""
        self.panel.show_frames_known(frames)
        self.frames_view.show(frames)
        for behavior in self.panel.sends:
            self.recheck(behavior)
        self.fields_changed()

    def _sender(self, send: SendFn, behavior: str) -> Callable[[Any], None]:
        return lambda _: self._send_typed(send, behavior, lambda: self.params(behavior))

    def params(self, behavior: str) -> dict[str, Any]:
        """The request as the fields show it; FieldError while a field's text is not a number."""
        return self.panel.params(behavior)

    def recheck(self, behavior: str) -> None:
        """Check the request as typed by the robot's own rules; say what they say, at once, at
        the fields; then the PTWL's target shows what they allow."""
        with self.client.atomic():
            try:
                params = self.params(behavior)
            except FieldError:
                self.panel.show_unreadable(behavior)
            else:
                self.panel.show_check(behavior, self._check(behavior, params))
            if behavior == "ptwl":
                self.update_contemplated(move_gizmo=True)

    def contemplated_target(self) -> Pose | None:
        return self._target(self._port())[0]

    def fields_changed(self) -> None:
        with self.client.atomic():
            self.update_contemplated(move_gizmo=True)

    def update_contemplated(self, move_gizmo: bool = False) -> None:
        port = self._port()
        target, why_not = self._target(port)
        self.contemplated.show(target, port[0] if port is not None else None)
        self.panel.show_contemplated(self.contemplated.distance_mm, why_not)
        show = bool(self.panel.show_gizmo.value) and target is not None
        appearing = show and not self.gizmo.visible
        self.gizmo.visible = show
        if show and target is not None and (move_gizmo or appearing):
            self._syncing_gizmo = True
            self.gizmo.position, self.gizmo.wxyz = target
            self._syncing_gizmo = False

    def _target(self, port: Pose | None) -> tuple[Pose | None, str]:
        """Where the PTWL as typed goes; None, and why, without a port, in a frame not known
        (yet), or while the translation or rotation is not numbers the robot's rules take."""
        if port is None:
            return None, "no robot state yet"
        try:
            return ptwl_target(port, *self.panel.ptwl_values(), self._frames()), ""
        except UnknownNameError:
            return None, f"frame {self.panel.frame.value} not known"
        except FieldError as err:
            return None, err.reason

    def _gizmo_moved(self) -> None:
        port = self._port()
        if self._syncing_gizmo or port is None:
            return
        target = (np.asarray(self.gizmo.position), np.asarray(self.gizmo.wxyz))
        try:
            translation, rotation = displacement_to(port, target, str(self.panel.frame.value), self._frames())
        except UnknownNameError:
            return  # the frame went away under the gizmo: the check line says so

        self.panel.set_ptwl_displacement(translation, rotation)
