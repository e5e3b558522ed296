"""One browser's desk: its own form, its own contemplated target and gizmo, and its place in the
control seat. What it sends goes through the console's shared `send` (one path for every desk)."""

from collections.abc import Callable
from typing import Any

import numpy as np
import viser

from robot_sim.errors import UnknownNameError
from robot_sim.task_frames import TaskFrames
from web.checks import Check
from web.defaults import ConsoleDefaults
from web.frames_view import FramesView
from web.markers import TargetMarker
from web.markup import show
from web.panel import Panel, preview_html
from web.preview import PreviewResult
from web.preview_marks import PreviewMarks
from web.seat import ControlSeat, operator_name
from web.targets import Pose, displacement_to, ptwl_target

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
            (0.0, 0.0, -0.09),
            distance_anchor="top-right",  # the commanded line's length is written bottom-left
        )
        self.gizmo = scene.add_transform_controls("/gizmo", scale=0.08, visible=False)
        self.preview_marks = PreviewMarks(scene)
        self.frames_view = FramesView(scene)
        panel = self.panel
        # Frames: add at the tool or a typed pose (the name typed), delete one (None: no pose).
        panel.add_frame_at_tool.on_click(lambda _: edit_frame(self, str(panel.new_frame_name.value), "tool"))
        panel.add_frame_typed.on_click(
            lambda _: edit_frame(self, str(panel.new_frame_name.value), panel.typed_frame_pose())
        )
        panel.delete_frame.on_click(lambda _: edit_frame(self, str(panel.delete_frame_name.value), None))
        panel.delete_frame_name.on_update(lambda _: panel.refresh_buttons())
        panel.show_frames.on_update(lambda _: self.frames_view.set_visible(bool(panel.show_frames.value)))
        panel.take_control.on_click(lambda _: seat.take(client.client_id))
        for behavior, button in panel.sends.items():
            button.on_click(self._sender(send, behavior))
        panel.send_step.on_click(lambda _: send(self, "ptwl", panel.step_params()))
        panel.preview.on_click(lambda _: preview(self))
        for behavior, form in panel.forms.items():  # Enter in one of the tab's fields
            form.on_submit(self._key_sender(send, behavior))
        for field in (panel.translation, panel.rotation, panel.frame, panel.show_gizmo):
            field.on_update(lambda _: self.fields_changed())
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
                send(self, behavior, self.params(behavior))

        return send_if_enabled

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
        return lambda _: send(self, behavior, self.params(behavior))

    def params(self, behavior: str) -> dict[str, Any]:
        return self.panel.params(behavior)

    def recheck(self, behavior: str) -> None:
        """Check the request as typed by the robot's own rules; say what they say, at once."""
        result = self._check(behavior, self.params(behavior))
        watchdog = getattr(result.params, "watchdog", None)
        self.panel.show_check(behavior, result.errors, result.warnings, watchdog)

    def contemplated_target(self) -> Pose | None:
        return self._target_or_none(self._port())

    def fields_changed(self) -> None:
        with self.client.atomic():
            self.update_contemplated(move_gizmo=True)

    def update_contemplated(self, move_gizmo: bool = False) -> None:
        port = self._port()
        target = self._target_or_none(port)
        self.contemplated.show(target, port[0] if port is not None else None)
        show = bool(self.panel.show_gizmo.value) and target is not None
        appearing = show and not self.gizmo.visible
        self.gizmo.visible = show
        if show and target is not None and (move_gizmo or appearing):
            self._syncing_gizmo = True
            self.gizmo.position, self.gizmo.wxyz = target
            self._syncing_gizmo = False

    def _target_or_none(self, port: Pose | None) -> Pose | None:
        """Where the PTWL as typed goes; None without a port, or in a frame not known (yet)."""
        if port is None:
            return None
        try:
            return ptwl_target(port, *self.panel.ptwl_values(), self._frames())
        except UnknownNameError:
            return None

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
