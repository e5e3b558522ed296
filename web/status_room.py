"""The status bar's model: one `BarInputs` a tick, read from the rooms that know each part (the
link, the command log, STOP, the seat, the scene, the twin), so no two lines can disagree; and
what else is drawn from it each tick (the ghost's label, the robot's STALE look)."""

import time

import viser

from web.command_log import CommandLog
from web.commanding import Commanding
from web.link_plan import clock_text, duration_text, has_schedule, schedule_line, signal
from web.robot_link import RobotLink
from web.robot_view import RobotView
from web.scene_keeper import SceneKeeper
from web.seat import ControlSeat, operator_name
from web.status_bar import BarInputs, Level, StatusBar
from web.twin_room import TwinRoom
from web.twin_trust import TwinTrust, ghost_label, twin_readout


class StatusRoom:
    def __init__(
        self,
        gui: viser.GuiApi,
        link: RobotLink,
        log: CommandLog,
        commanding: Commanding,
        seat: ControlSeat,
        scene: SceneKeeper,
        twin: TwinRoom | None,
        view: RobotView,
    ) -> None:
        self._link, self._log, self._commanding, self._seat = link, log, commanding, seat
        self._scene, self._twin, self._view = scene, twin, view
        self.recording = ""  # a replay's file name: the bar says it is a recording
        self._level: Level = "stale"
        self._los_label: str | None = None  # the robot's label through a loss of signal
        self.bar = StatusBar(gui, self.inputs, self.on_level, self.on_tick)  # drawn from this model

    def inputs(self) -> BarInputs:
        state, arrived = self._link.latest()
        history = self._log.history
        running = history.live()
        shown = running[0] if running else history.latest()
        command = (
            f"{shown.behavior.upper()} {shown.short_label}: {shown.status}" if shown else "no command yet"
        )
        if shown is not None and shown.sender:  # the operator; the history has the console too
            command += f" (by {shown.sender.split(' at console')[0]})"
        if len(running) > 1:
            command += f" · {len(running) - 1} more queued"
        if shown is not None and shown.phase == "sent" and shown.detail:
            command += f" · {shown.detail}"  # held by the link for its next contact
        outlook = self._link.outlook()
        now = time.time()
        every_s = self._link.health.every_s
        scheduled = outlook is not None and has_schedule(self._link.profile())
        lost_since = signal(outlook, now).lost_since if outlook is not None and scheduled else None
        rtt = self._link.rtt_s()
        twin = self._twin
        prediction = twin.prediction if twin is not None else None
        trust, readout = twin_readout(time.time(), twin.twin) if twin is not None else (None, "")
        return BarInputs(
            state,
            arrived,
            self._link.link_up,
            self._link.health.line(rtt, now, out_of_contact=lost_since is not None),
            rtt,
            command,
            self._log.restart_note,
            scene_note=self._scene.note,
            stop=self._commanding.stopper.state,
            holder=operator_name(self._seat.holder) or "",
            predicted_port=tuple(prediction.port[0].tolist()) if prediction is not None else None,
            prediction_error=twin.twin.error_summary() if twin is not None else None,
            twin_readout=readout,
            twin_sure=trust is not None and trust.sure,
            twin_note=twin.idle_note() if twin is not None else "",
            recording=self.recording,
            schedule=schedule_line(outlook, now, every_s) if outlook is not None and scheduled else "",
            lost_since=lost_since,
            state_every_s=every_s or 0.0,
        )

    def on_tick(self, inputs: BarInputs) -> None:
        """(the bar's thread) The ghost's label, from the bar's own readout: drawn here only, so
        the twin's 50 Hz thread does no second judging, and a lagging twin is still labelled."""
        if self._twin is not None and inputs.predicted_port is not None:
            self._twin.ghost.set_label(ghost_label(TwinTrust(inputs.twin_sure), inputs.twin_readout))
        self._show_loss_of_signal(inputs)

    def _show_loss_of_signal(self, inputs: BarInputs) -> None:
        """Through a loss of signal the robot is drawn grey with the time since the last contact
        (once a second: the label's text); after it, as its state's trust says."""
        if inputs.lost_since is None:
            if self._los_label is not None:
                self._los_label = None
                self.on_level(self._level)
            return
        since = inputs.lost_since
        label = f"LOSS OF SIGNAL since {clock_text(since)} ({duration_text(time.time() - since)})"
        if label != self._los_label:
            self._los_label = label
            self._view.set_stale(True, label)

    def on_level(self, level: Level) -> None:
        self._level = level
        if self._los_label is not None:
            return  # the loss of signal's label stands until contact is back
        silent_s = self._link.health.silent_s(time.time())
        said = "link down" if not self._link.link_up else f"no telemetry for {silent_s or 0.0:.0f} s"
        self._view.set_stale(level == "stale", f"STALE: {said}")
