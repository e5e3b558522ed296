"""One browser's desk: its own form, its own contemplated target and gizmo, and its place in the
control seat. What it sends goes through the console's shared `send` (one path for every desk),
and only what its fields show: a field whose text is not a number (FieldError) sends nothing,
previews nothing and draws no target."""

import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import viser

from robot_sim.behaviors.base import PoseArrays
from robot_sim.errors import UnknownNameError
from robot_sim.task_frames import TaskFrames
from web.checks import Check
from web.defaults import ConsoleDefaults
from web.desk_preview import DeskPreview
from web.frames_view import FramesView
from web.label_places import CONTEMPLATED
from web.link_plan import SendPlan
from web.markers import TargetMarker
from web.markup import Markup, add_html
from web.panel import Panel
from web.preview import PreviewResult
from web.seat import ControlSeat, operator_name
from web.targets import displacement_to, ptwl_target
from web.typed_number import FieldError

YELLOW = (250, 204, 21)


class DeskServices(Protocol):
    """What a desk asks of the console (web/commanding.py): the robot's port and task frames as
    last heard, its rules, and the ways to act on it."""

    def port(self) -> PoseArrays | None: ...

    @property
    def task_frames(self) -> TaskFrames: ...

    def check(self, behavior: str, params: dict[str, Any]) -> Check: ...

    def send(self, desk: "Desk", behavior: str, params: dict[str, Any]) -> None: ...

    def preview(self, request: dict[str, Any]) -> tuple[PreviewResult | None, str]: ...

    def edit_frame(self, desk: "Desk", name: str, pose: "dict[str, list[float]] | str | None") -> None: ...

    def machine(self) -> tuple[dict[str, Any] | None, float | None]: ...

    def decide(self, desk: "Desk", command_id: int, body: dict[str, Any]) -> None: ...

    def plan_send(self, behavior: str, params: dict[str, Any]) -> tuple[SendPlan, float | None]: ...


@dataclass(frozen=True)
class DeskCatalog:
    """What every desk's form offers: the console's defaults and the robot's catalog."""

    defaults: ConsoleDefaults
    stiffness_presets: dict[str, dict[str, Any]]
    dither_presets: dict[str, dict[str, Any]]
    tasks: dict[str, str]  # name: summary


class Desk:
    def __init__(
        self, client: viser.ClientHandle, catalog: DeskCatalog, seat: ControlSeat, services: DeskServices
    ) -> None:
        self.client = client
        self.name = operator_name(client.client_id) or ""
        self._seat = seat
        self._services = services
        self._syncing_gizmo = False
        # The contemplated target is redrawn from the fields on every state (the telemetry's
        # thread) and on every edit (viser's): each reads the fields and then draws, and a state's
        # redraw that read the fields before an edit must not draw after it (the label said
        # |(20, -10, 0)| mm under (20, -10, 5) until the next state, which a blackout delays).
        self._contemplating = threading.RLock()
        self.panel = Panel(
            client.gui, catalog.defaults, catalog.stiffness_presets, catalog.dither_presets, catalog.tasks
        )
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
        preview_line = self.panel.ptwl.step.preview_html
        self.preview = DeskPreview(scene, preview_line, services.preview, self._typed_ptwl)
        self.frames_view = FramesView(scene)
        machines = self.panel.machines
        self.machine_preview = DeskPreview(
            scene, machines.preview_line, services.preview, machines.next_step, root="/machine_preview"
        )
        self._machine_shown: tuple[Any, ...] | None = None
        for button, choice in (
            (machines.confirm, "confirm"),
            (machines.decide_outcome, "outcome"),
            (machines.force, "force"),
            (machines.stop_machine, "stop"),
        ):
            button.on_click(self._decider(choice))
        machines.preview_next.on_click(lambda _: self._preview_next())
        panel = self.panel
        edit_frame = services.edit_frame
        # Frames: add at the tool or a typed pose (the name typed), delete one (None: no pose).
        panel.frames.add_frame_at_tool.on_click(
            lambda _: edit_frame(self, str(panel.frames.new_frame_name.value), "tool")
        )
        panel.frames.add_frame_typed.on_click(lambda _: self._add_typed_frame())
        panel.frames.delete_frame.on_click(
            lambda _: edit_frame(self, str(panel.frames.delete_frame_name.value), None)
        )
        panel.frames.delete_frame_name.on_update(lambda _: panel.refresh_buttons())
        panel.frames.show_frames.on_update(
            lambda _: self.frames_view.set_visible(bool(panel.frames.show_frames.value))
        )
        panel.control.take_control.on_click(lambda _: self._take_control())
        for behavior, button in panel.sends.items():
            button.on_click(self._sender(behavior))
        panel.ptwl.step.send_step.on_click(lambda _: self._send_typed("ptwl", panel.ptwl.step_params))
        panel.ptwl.step.preview.on_click(lambda _: self._preview())
        for behavior, form in panel.forms.items():  # Enter in one of the tab's fields
            form.on_submit(self._key_sender(behavior))
        # The target follows the PTWL's fields through its check (recheck), which first says
        # whether the robot's rules take them; the gizmo's box has no rule.
        panel.ptwl.show_gizmo.on_update(lambda _: self.fields_changed())
        for behavior in panel.sends:
            for field in panel.fields(behavior):
                field.on_update(lambda _, b=behavior: self.recheck(b))
        self.gizmo.on_update(lambda _: self._gizmo_moved())
        # Page keys (viser's command palette hotkeys, which act once the focus has left a text
        # field, e.g. after dragging the target in 3D): Enter sends the PTWL as Send would, Escape
        # clears the contemplated target back to "no move".
        send_key = client.gui.add_command("Send PTWL", description="as the Send cmd button", hotkey="enter")
        send_key.on_trigger(self._key_sender("ptwl"))
        clear_key = client.gui.add_command(
            "Clear target", description="translation and rotation to 0", hotkey="escape"
        )
        clear_key.on_trigger(lambda _: self.clear_contemplated())
        self.seat_changed()
        for behavior in self.panel.sends:
            self.recheck(behavior)

    @property
    def client_id(self) -> int:
        return self.client.client_id

    def _key_sender(self, behavior: str) -> Callable[[Any], None]:
        """A key's send: only what the tab's button would send now (in control, valid)."""

        def send_if_enabled(_: Any) -> None:
            if not self.panel.sends[behavior].disabled:
                self._send_typed(behavior, lambda: self.params(behavior))

        return send_if_enabled

    def _send_typed(self, behavior: str, make: Callable[[], dict[str, Any]]) -> None:
        """Send what `make` reads from the fields, unless a field's text is not a number (its
        button is off then; this holds a click or key that came before the button turned off).
        A preview on show was of what came before: it goes."""
        try:
            params = make()
        except FieldError as err:
            self.client.add_notification("Not sent: a field is marked in red", err.reason, color="red")
            return
        plan, valid_until = self._services.plan_send(behavior, params)
        if plan.ask_first:
            self._confirm_before_los(behavior, params, plan.text, valid_until)
            return
        self.preview.clear()
        self._services.send(self, behavior, params)

    def _confirm_before_los(
        self, behavior: str, params: dict[str, Any], warning: str, valid_until: float | None
    ) -> None:
        """The command may not finish before the next loss of signal: say so and offer to send
        it so it will not start too late (valid_until_sim_time), as it is, or not at all."""
        gui = self.client.gui
        with gui.add_modal("Signal may be lost before it finishes") as modal:
            add_html(gui, Markup('<p id="ptwl-los-warning">{}</p>').format(warning))
            buttons = []
            if valid_until is not None:
                limited = gui.add_button(
                    f"Send: start by sim time {valid_until:.1f} s at the latest", color="green"
                )
                buttons.append((limited, {**params, "valid_until_sim_time": round(valid_until, 3)}))
            else:
                add_html(gui, Markup("<p>It cannot start in time to finish before then.</p>"))
            buttons.append((gui.add_button("Send as it is", color="orange"), params))
            cancel = gui.add_button("Cancel", color="gray")

        def sender(body: dict[str, Any]) -> Callable[[Any], None]:
            def send(_: Any) -> None:
                modal.close()
                self.preview.clear()
                self._services.send(self, behavior, body)

            return send

        for button, body in buttons:
            button.on_click(sender(body))
        cancel.on_click(lambda _: modal.close())

    def _take_control(self) -> None:
        """Take control at once when nobody has it; from another operator, only once confirmed
        (a take-over ends their commanding mid-task)."""
        holder = self._seat.holder
        if holder is None or holder == self.client_id:
            self._seat.take(self.client_id)
            return
        gui = self.client.gui
        with gui.add_modal("Take control?") as modal:
            add_html(
                gui,
                Markup(
                    "<p><b>{}</b> has control now. Taking it leaves them watching; they will be told.</p>"
                ).format(operator_name(holder)),
            )
            take = gui.add_button("Take control from them", color="orange")
            cancel = gui.add_button("Cancel", color="gray")

        def confirmed(_: Any) -> None:
            self._seat.take(self.client_id)
            modal.close()

        take.on_click(confirmed)
        cancel.on_click(lambda _: modal.close())

    def _decider(self, choice: str) -> Callable[[Any], None]:
        return lambda _: self._decide(choice)

    def _decide(self, choice: str) -> None:
        answer = self.panel.machines.decision_body(choice)
        if answer is not None:
            self._services.decide(self, *answer)

    def _preview_next(self) -> None:
        step = self.panel.machines.next_step()
        if step is not None:
            self.machine_preview.ask(step)

    def state_arrived(self) -> None:
        """A state: the contemplated target moves with the port; the running machine is shown."""
        self.update_contemplated()
        self.show_machine()

    def close_previews(self) -> None:
        self.preview.errands.close()
        self.machine_preview.errands.close()

    def show_machine(self) -> None:
        """The running machine as telemetry last said (its pending decision, the graph): redrawn
        only when it changed or the seat did (who may answer)."""
        machine, sim_time = self._services.machine()
        may = self._seat.holds(self.client_id)
        pending = (machine or {}).get("pending")
        # While a decision waits, its waiting time is shown to the tenth of a second.
        shown = (repr(machine), may, round(sim_time, 1) if pending and sim_time is not None else None)
        if shown == self._machine_shown:
            return
        self._machine_shown = shown
        with self.client.atomic():
            self.panel.machines.show_running(machine, sim_time, may)
            self.machine_preview.refresh()

    def _preview(self) -> None:
        try:
            request = self.params("ptwl")
        except FieldError as err:
            self.preview.show(None, f"no preview: {err.reason}")
            return
        self.preview.ask(request)

    def _add_typed_frame(self) -> None:
        try:
            pose = self.panel.frames.typed_pose()
        except FieldError as err:
            self.client.add_notification("Frame not added: a field is marked in red", err.reason, color="red")
            return
        self._services.edit_frame(self, str(self.panel.frames.new_frame_name.value), pose)

    def _typed_ptwl(self) -> dict[str, Any] | None:
        try:
            return self.params("ptwl")
        except FieldError:
            return None

    def clear_contemplated(self) -> None:
        self.panel.ptwl.set_displacement(np.zeros(3), np.zeros(3))
        self.fields_changed()
        self.recheck("ptwl")

    def seat_changed(self) -> None:
        holder = self._seat.holder
        self.panel.show_control(holder == self.client_id, operator_name(holder))
        self.show_machine()  # who may answer a decision

    def show_frames(self, frames: list[dict[str, Any]]) -> None:
        """The robot's task frames changed (or first became known): offer them, draw them, and
        check the requests again (a frame a field names may be gone)."""
        self.panel.show_frames_known(frames)
        self.frames_view.show(frames)
        for behavior in self.panel.sends:
            self.recheck(behavior)
        self.fields_changed()

    def _sender(self, behavior: str) -> Callable[[Any], None]:
        return lambda _: self._send_typed(behavior, lambda: self.params(behavior))

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
                self.panel.show_check(behavior, self._services.check(behavior, params))
            if behavior == "ptwl":
                self.update_contemplated(move_gizmo=True)
                self.preview.refresh()

    def fields_changed(self) -> None:
        with self.client.atomic():
            self.update_contemplated(move_gizmo=True)

    def update_contemplated(self, move_gizmo: bool = False) -> None:
        """Redraw the contemplated target (and the gizmo) from the fields as they are now: read
        and drawn under one lock, so the last redraw is of the latest fields."""
        with self._contemplating:
            port = self._services.port()
            target, why_not = self._target(port)
            self.contemplated.show(target, port[0] if port is not None else None)
            self.panel.ptwl.show_contemplated(self.contemplated.distance_mm, why_not)
            show = bool(self.panel.ptwl.show_gizmo.value) and target is not None
            appearing = show and not self.gizmo.visible
            self.gizmo.visible = show
            if show and target is not None and (move_gizmo or appearing):
                self._syncing_gizmo = True
                self.gizmo.position, self.gizmo.wxyz = target
                self._syncing_gizmo = False

    def _target(self, port: PoseArrays | None) -> tuple[PoseArrays | None, str]:
        """Where the PTWL as typed goes; None, and why, without a port, in a frame not known
        (yet), or while the translation or rotation is not numbers the robot's rules take."""
        if port is None:
            return None, "no robot state yet"
        try:
            return ptwl_target(port, *self.panel.ptwl.values(), self._services.task_frames), ""
        except UnknownNameError:
            return None, f"frame {self.panel.ptwl.frame.value} not known"
        except FieldError as err:
            return None, err.reason

    def _gizmo_moved(self) -> None:
        port = self._services.port()
        if self._syncing_gizmo or port is None:
            return
        target = (np.asarray(self.gizmo.position), np.asarray(self.gizmo.wxyz))
        try:
            translation, rotation = displacement_to(
                port, target, str(self.panel.ptwl.frame.value), self._services.task_frames
            )
        except UnknownNameError:
            return  # the frame went away under the gizmo: the check line says so

        self.panel.ptwl.set_displacement(translation, rotation)
