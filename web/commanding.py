"""What the operators' desks do to the robot: check a request by the robot's own rules, preview a
PTWL on the twin, send (only the one in control; stamped with its expiry and who sent it), edit
task frames, and STOP (anyone; retried until confirmed: web/stop_sender.py)."""

import json
import math
import time
from typing import TYPE_CHECKING, Any

import httpx
import numpy as np
import viser

from robot_sim.behaviors import BehaviorParams
from robot_sim.behaviors.base import PoseArrays
from robot_sim.errors import UnknownNameError
from robot_sim.params import PtwlParams
from robot_sim.task_frames import TaskFrames
from robot_sim.telemetry import gains_of
from server.client import RobotError
from server.models import StopResult
from web.checks import Check, check_command
from web.command_log import CommandLog
from web.defaults import ConsoleDefaults
from web.history import CommandView
from web.known_frames import KnownFrames
from web.link_plan import SendPlan, clock_text, plan_send, run_time_s, sim_time_at
from web.notifier import Notifier
from web.preview import Previewer, PreviewResult
from web.robot_link import HTTP_TIMEOUT_S, RobotLink
from web.seat import ControlSeat, operator_name
from web.stop_sender import StopSender
from web.targets import ptwl_target
from web.twin import GroundTwin, Sent
from web.twin_sim import point_from_state

if TYPE_CHECKING:
    from web.desk import Desk


# [s] the longest a console waits on a command the link holds for its next contact; past it the
# console gives up (the link then lets the request go, and the log says "not delivered").
MAX_HELD_WAIT_S = 3 * 3600.0
REQUEST_HEAD_BYTES = 400  # [bytes] a command request's line and headers, about (its body is counted)


class Commanding:
    def __init__(
        self,
        link: RobotLink,
        frames: KnownFrames,
        log: CommandLog,
        seat: ControlSeat,
        defaults: ConsoleDefaults,
        notifier: Notifier,
        console_name: str,  # "host:port": who sent it, with the operator's name
    ) -> None:
        self._link, self._frames, self._log, self._seat = link, frames, log, seat
        self._defaults, self._notifier, self._console_name = defaults, notifier, console_name
        self.twin: GroundTwin | None = None  # set when the predictive display runs
        self.previewer = Previewer()
        self.stopper = StopSender(
            lambda timeout_s: link.client.stop(timeout=timeout_s),
            link.rtt_s,
            lambda _: None,  # the bar draws `stopper.state` on its next tick
            self._stop_confirmed,
        )

    # ------------------------------------------------------------- reads
    def port(self) -> PoseArrays | None:
        return self._link.port()

    @property
    def task_frames(self) -> TaskFrames:
        return self._frames.task_frames

    def check(self, behavior: str, params: dict[str, Any]) -> Check:
        """A request checked by the robot's rules against the state shown (gains and port now)."""
        state, _ = self._link.latest()
        now = state["gains"] if state else None
        gains = gains_of(now) if now else None
        q_world_port = np.asarray(state["port"]["quaternion"]) if state else None
        return check_command(behavior, params, gains, q_world_port, self._frames.task_frames)

    def preview(self, request: dict[str, Any]) -> tuple[PreviewResult | None, str]:
        """Run a PTWL request on a copy of the model from where the twin puts the robot now (from
        the latest telemetry when no twin runs: on a short link that is now): (how it ends, where
        it started), or (None, why there is none)."""
        checked = self.check("ptwl", request)
        state, _ = self._link.latest()
        point = self.twin.point if self.twin is not None else None
        note = "" if point is not None else "from the latest telemetry"
        if point is None and state is not None:
            point = point_from_state(state, self._frames.task_frames)
        if not isinstance(checked.params, PtwlParams):
            return None, f"no preview: {checked.errors}"
        if point is None:
            return None, "no preview: no robot state yet"
        return self.previewer.run(point, checked.params), note

    # ------------------------------------------------------------- sends
    def send(self, desk: "Desk", behavior: str, params: dict[str, Any]) -> None:
        """Send from a desk: only the one holding control; the record says who sent it."""
        if not self._seat.holds(desk.client_id):
            desk.client.add_notification(
                "Not sent: you are watching", "Take control to send commands.", color="red"
            )
            return
        sender = f"{desk.name} at console {self._console_name}"
        target = self.target_of(params) if behavior == "ptwl" else None  # Send step's: the step's
        view = self._log.sent(behavior, target, sender)
        try:
            self._deliver(view, behavior, params, sender)
        except Exception as err:
            # Not sent after all (a check, the twin, the answer's parsing): never left "sent",
            # which would hold every event of its behavior as maybe its own (web/history.py).
            if view.phase == "sent":
                self._log.refused(view, f"not sent: {type(err).__name__}: {err}")
            raise

    def _deliver(self, view: CommandView, behavior: str, params: dict[str, Any], sender: str) -> None:
        """Send `view`'s command over the link, held for its uplink contact if need be; the answer
        (accepted or refused) onto the view."""
        now = time.time()
        # A closed uplink holds the command for its next contact: it is that much older when it
        # arrives (max_age), and its answer that much later (the HTTP wait).
        held_until = self.plan_send(behavior, params)[0].held_until
        held_s = 0.0 if held_until is None else min(held_until - now, MAX_HELD_WAIT_S)
        if held_until is not None:
            view.detail = (
                f"held by the link for the next contact at {clock_text(held_until)}"
                if math.isfinite(held_until)
                else "held by the link: no uplink contact left in its plan"
            )
            self._log.changed(view)
        max_age_s = self._link.rtt_s() + held_s + self._defaults.max_age_over_rtt_s
        stamped = {"max_age": max_age_s, "sent_at": now, **params}
        checked = self.check(behavior, stamped).params
        if self.twin is not None and isinstance(checked, BehaviorParams):  # the ghost moves at once
            self.twin.on_sent(Sent(checked, stamped["sent_at"], lambda: view.phase in ("sent", "queued")))
        try:
            wait_s = HTTP_TIMEOUT_S + held_s if held_until is not None else None
            accepted = self._link.client.command(behavior, sender=sender, http_timeout_s=wait_s, **stamped)
        except RobotError as err:
            self._log.refused(view, str(err.detail))
            self._notifier.notify("Command refused", str(err.detail), "red")
        except httpx.HTTPError as err:
            self._log.refused(view, f"link: {type(err).__name__}")
            self._notifier.notify("Command not delivered", f"{type(err).__name__}: {err}", "red")
        else:
            if held_until is not None:
                view.detail = ""  # it has arrived
            self._log.accepted(view, accepted.id)
            for warning in accepted.warnings:
                self._notifier.notify(f"#{accepted.id}: check the approach", warning, "orange")

    def plan_send(self, behavior: str, params: dict[str, Any]) -> tuple[SendPlan, float | None]:
        """What the link's schedule means for this command sent now (web/link_plan.py), and the
        robot's sim time of its latest start that still finishes before the loss of signal (None:
        there is none, or no state to tell the robot's time by)."""
        checked = self.check(behavior, params).params
        profile = self._link.profile() or {}
        plan = plan_send(
            self._link.outlook(),
            time.time(),
            run_time_s(checked) if checked else None,
            len(json.dumps(params)) + REQUEST_HEAD_BYTES,
            (profile.get("schedule") or {}).get("mode", "store"),
        )
        state, _ = self._link.latest()
        if plan.latest_start is None or state is None:
            return plan, None
        return plan, sim_time_at(plan.latest_start, state)

    def target_of(self, params: dict[str, Any]) -> PoseArrays | None:
        """Where a PTWL as sent goes from the port shown (None without a port, or in a frame not
        known yet): the commanded marker's place, from what is sent, not from the fields."""
        port = self._link.port()
        if port is None:
            return None
        try:
            return ptwl_target(
                port,
                np.asarray(params["translation"], dtype=float),
                np.asarray(params["rotation"], dtype=float),
                str(params["frame"]),
                self._frames.task_frames,
            )
        except UnknownNameError:
            return None

    def edit_frame(self, desk: "Desk", name: str, pose: "dict[str, list[float]] | str | None") -> None:
        """Add a task frame at `pose` (`tool`, or a typed pose), or delete `name` (None); only the
        operator in control, as for commands. The robot's `frames` message follows for everyone."""
        if not self._seat.holds(desk.client_id):
            desk.client.add_notification(
                "Not done: you are watching", "Take control to edit frames.", color="red"
            )
            return
        client = self._link.client
        try:
            changed = client.delete_frame(name) if pose is None else client.add_frame(name, pose)
        except (RobotError, httpx.HTTPError) as err:
            reason = str(err.detail) if isinstance(err, RobotError) else f"{type(err).__name__}: {err}"
            self._notifier.notify("Frame not changed", reason, "red")
            return
        self._frames.edited(changed.name, None if pose is None else changed.model_dump())

    def machine(self) -> tuple[dict[str, Any] | None, float | None]:
        """(telemetry's running machine, the robot's sim time) as last heard."""
        state, _ = self._link.latest()
        return (state.get("machine"), float(state["sim_time"])) if state is not None else (None, None)

    def decide(self, desk: "Desk", command_id: int, body: dict[str, Any]) -> None:
        """Answer the running machine's pending decision: only the operator in control, as for
        commands; across the link like any command (a late answer is refused by its number)."""
        if not self._seat.holds(desk.client_id):
            desk.client.add_notification(
                "Not decided: you are watching", "Take control to answer decisions.", color="red"
            )
            return
        try:
            self._link.client.decide(command_id, **body)
        except RobotError as err:
            self._notifier.notify("Decision refused", str(err.detail), "red")
        except httpx.HTTPError as err:
            self._notifier.notify("Decision not delivered", f"{type(err).__name__}: {err}", "red")

    # -------------------------------------------------------------- STOP
    def stop(self, client: viser.ClientHandle | None = None) -> None:
        """Anyone may stop. The bar shows it pending until the robot confirms; a failure stays on
        screen, in red at STOP, and STOP is sent again until one is confirmed (StopSender)."""
        who = (operator_name(client.client_id) if client is not None else None) or "console"
        if self.twin is not None:
            self.twin.on_stop(time.time())
        self.stopper.press(who)

    def _stop_confirmed(self, result: StopResult) -> None:
        """(the STOP thread) The robot says what STOP ended: every line says so at once."""
        if self.twin is not None:
            self.twin.on_stop_confirmed(result.aborted)
        self._log.stopped(result.aborted, result.dropped)
