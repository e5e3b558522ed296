"""The operator console: viser GUI + 3D scene, talking to the robot only through the link.

What the operator sees, after the teleoperation paper: intent at once (each browser's own
contemplated target while typing, the commanded target from Send), the robot as it reports itself
when that report arrives (with how old it is, counted on while nothing arrives), and each
command's life with its exit condition and who sent it. One browser holds control at a time.

The pieces own their handles: `StatusBar` (pinned; age, link, task, STOP), `Board` (what every
browser shares), `Desk` (one per browser), `RobotView` (the 3D scene), `TelemetryFeed` and
`LinkPoller` (threads, stopped by `close()`).
"""

import threading
import time
from typing import Any, Literal

import httpx
import numpy as np
import viser

from robot_sim.behaviors import BehaviorParams
from robot_sim.errors import UnknownNameError
from robot_sim.gains import Gains
from robot_sim.params import PtwlParams
from robot_sim.task_frames import TaskFrames, frames_from_dicts
from server.client import RobotClient, RobotError
from server.models import GeometryModel, StopResult
from web.board import Board
from web.checks import Check, check_command
from web.defaults import load_defaults
from web.desk import Desk
from web.feed import TelemetryFeed
from web.front_door import FrontDoor, admit_only_through
from web.ghost import GhostView
from web.handshake import Catalog, Handshake
from web.history import CommandHistory, CommandView
from web.link_poller import LinkPoller
from web.playback import Playback, replay_status
from web.preview import Previewer
from web.robot_view import INITIAL_CAMERA, RobotView
from web.seat import ControlSeat, operator_name
from web.status_bar import BarInputs, Level, StatusBar
from web.stop_sender import StopSender
from web.targets import Pose, ptwl_target
from web.telemetry_health import TelemetryHealth
from web.twin import GroundTwin, Prediction, Sent, point_from_state
from web.twin_trust import twin_readout
from web.twin_worker import TwinWorker

NotificationColor = Literal["gray", "red", "green", "orange", "yellow", "blue"]
HTTP_TIMEOUT_S = 120.0  # requests cross the link twice; long delays are the point
PLOT_EVERY = 5  # telemetry messages per plot refresh (10 Hz at 50 Hz telemetry)
RECORDS_ON_RECONNECT = 100  # how many of the robot's recent records to re-read


class ConsoleApp:
    def __init__(
        self,
        robot_url: str,
        host: str = "127.0.0.1",
        port: int = 8080,
        token: str | None = None,
        allow_origins: tuple[str, ...] = (),
        replay: bool = False,
    ):
        self.robot_url = robot_url.rstrip("/")
        self.token = token
        self.replay = replay  # the robot is `ptwl replay`'s stand-in for a recording
        self.client = RobotClient(self.robot_url, token=token, timeout=HTTP_TIMEOUT_S)
        self.defaults = load_defaults()
        # viser checks no Origin: it listens on an ephemeral loopback port behind the front door.
        self.server = viser.ViserServer(host="127.0.0.1", port=0, label="ptwl console", verbose=False)
        self.front_door = FrontDoor(host, port, self.server.get_port(), allow_origins)
        admit_only_through(self.front_door, self.server)
        self._host = host
        self._front_port = self.front_door.start()
        self.server.initial_camera.position, self.server.initial_camera.look_at = INITIAL_CAMERA
        self.server.gui.configure_theme(control_width="large", dark_mode=False)
        self.history = CommandHistory()
        self.seat = ControlSeat()
        self._lock = threading.Lock()
        self._state: dict[str, Any] | None = None
        self._arrived: float | None = None
        self._link_up = False
        self.telemetry_health = TelemetryHealth()
        self._restart_note = ""
        self._commanded: CommandView | None = None
        self._count = 0
        self._reconciling = threading.Lock()
        self.scene_name = ""
        self._closed = False
        self._desks: dict[int, Desk] = {}
        self.view: RobotView | None = None
        self.board: Board | None = None
        self.bar: StatusBar | None = None
        self.feed: TelemetryFeed | None = None
        self.link_poller: LinkPoller | None = None
        self.playback: Playback | None = None  # when the robot is a recording
        self.handshake: Handshake | None = None
        self.twin: GroundTwin | None = None  # the predictive display (not for a recording)
        self.ghost: GhostView | None = None
        self.twin_worker: TwinWorker | None = None
        self._prediction: Prediction | None = None
        self.previewer = Previewer()
        self._recording = ""  # a replay's file name: the bar says it is a recording
        self._scene_note = ""  # a reset on its way, or a new scene not drawn yet
        self.stopper = StopSender(
            lambda timeout_s: self.client.stop(timeout=timeout_s),
            lambda: self.link_poller.rtt_s if self.link_poller is not None else 0.0,
            lambda _: None,  # the bar draws `stopper.state` on its next tick
            self._stop_confirmed,
        )
        # The robot's task frames as last heard (GET /api/frames on a scene load, then its
        # `frames` telemetry messages): what the fields offer and the checks accept.
        self._frames_heard: list[dict[str, Any]] = []
        self._frames_lock = threading.RLock()
        self.task_frames = TaskFrames()

    @property
    def url(self) -> str:
        shown = f"[{self._host}]" if ":" in self._host else self._host
        return f"http://{shown}:{self._front_port}"

    # ---------------------------------------------------------------- start
    def connect(self, timeout: float | None = None) -> None:
        """Build the panels and the scene at once from the console's own copy of the robot's
        catalog (Send shows without waiting a round trip), and meet the robot in the background;
        with `timeout`, wait that long for it (the scene drawn) or raise."""
        replay = None
        if self.replay:  # a replay's stand-in is local, never behind a link: asking costs nothing
            replay = replay_status(self.robot_url, self.token)
            if replay is None:
                raise RuntimeError(f"{self.robot_url} is not a replay (GET /_replay did not answer)")
        local = Catalog.local()
        presets = dict(local.presets)
        self._dither_presets = presets.pop("dither")
        self._tasks = {t.name: t.summary for t in local.tasks}
        self._stiffness_presets = presets
        self.view = RobotView(self.server, self.defaults.wrench_arrow_m_per_n)
        self.bar = StatusBar(self.server.gui, self._bar_inputs, self._on_level, self._on_tick)
        scene_names = [s.name for s in local.scenes]
        self.board = Board(self.server.gui, scene_names, scene_names[0], self.defaults.plot_s)
        if replay is not None:
            self.playback = Playback(self.server.gui, self.robot_url, self.token, replay, self._replay_jumped)
            self.bar.stop.visible = False  # nothing moves on a recording
            self._recording = str(replay["file"]).rsplit("/", 1)[-1]
        self.bar.stop.on_click(lambda event: self.stop(event.client))
        self.board.reset_scene.on_click(lambda _: self.reset_scene())
        self.seat.on_change(self._seat_changed)
        self.server.on_client_connect(self._client_connected)
        self.server.on_client_disconnect(self._client_disconnected)
        # The meshes go out after the panels, when the robot has answered.
        self.handshake = Handshake(self.client, local, self._met_robot)
        self.handshake.start()
        self.feed = TelemetryFeed(
            self.client, self._on_state, self._on_command, self._on_link, self._set_frames
        )
        self.link_poller = LinkPoller(self.robot_url, self.token, self._on_link_profile)
        if self.defaults.twin and replay is None:
            self.twin = GroundTwin(self._uplink_s)
            self.ghost = GhostView(self.server)
            self.twin_worker = TwinWorker(
                self.twin,
                self.ghost,
                self.server,
                self._on_prediction,
                lambda: self.link_poller.rtt_s if self.link_poller is not None else 0.0,
                self.defaults.twin_min_rtt_s,
            )
            self.twin_worker.start()
        self.feed.start()
        self.link_poller.start()
        self.bar.start()
        if self.playback is not None:
            self.playback.start()
        if timeout is not None and not self.handshake.wait(timeout):
            raise RuntimeError(f"robot at {self.robot_url} not reachable within {timeout:g} s")

    def _met_robot(self, geometry: GeometryModel, differences: list[str]) -> None:
        """(handshake thread) The robot answered: draw its scene; say if its catalog differs."""
        if self._closed:
            return
        self._reload_geometry(geometry)
        if differences:
            self._notify(
                "This console is not the robot's version",
                f"the robot's {', '.join(differences)} differ from what this console shows; "
                "commands are checked by the robot, which names anything it does not know",
                "orange",
            )

    # ---------------------------------------------------------------- desks
    def _client_connected(self, client: viser.ClientHandle) -> None:
        if self._closed or self.playback is not None:
            return  # a replay is watched, not commanded: no form to send from
        desk = Desk(
            client,
            self.defaults,
            self._stiffness_presets,
            self._dither_presets,
            self._tasks,
            self.seat,
            self._port,
            self.send,
            self.check,
            self.preview,
            lambda: self.task_frames,
            self.edit_frame,
        )
        desk.panel.show_scene_task(self.scene_name)
        with self._frames_lock:
            desk.show_frames(self._frames_heard)
        with self._lock:
            self._desks[client.client_id] = desk

    def _client_disconnected(self, client: viser.ClientHandle) -> None:
        with self._lock:
            self._desks.pop(client.client_id, None)
        self.seat.release(client.client_id)

    def desks(self) -> list[Desk]:
        with self._lock:
            return list(self._desks.values())

    def _seat_changed(self, previous: int | None, new: int | None) -> None:
        for desk in self.desks():
            desk.seat_changed()
            if desk.client_id == previous and new is not None:
                desk.client.add_notification(
                    "Control taken",
                    f"{operator_name(new)} has control now; you are watching.",
                    color="orange",
                )

    # ------------------------------------------------------------- commands
    def _port(self) -> Pose | None:
        with self._lock:
            state = self._state
        if state is None:
            return None
        return np.asarray(state["port"]["position"]), np.asarray(state["port"]["quaternion"])

    def check(self, behavior: str, params: dict[str, Any]) -> Check:
        """A request checked by the robot's rules against the state shown (gains and port now)."""
        with self._lock:
            state = self._state
        now = state["gains"] if state else None
        gains = Gains.of(now["stiffness"], now["damping"], now["frame"]) if now else None
        q_world_port = np.asarray(state["port"]["quaternion"]) if state else None
        return check_command(behavior, params, gains, q_world_port, self.task_frames)

    def preview(self, desk: Desk) -> None:
        """Run the desk's PTWL on a copy of the model from where the twin puts the robot now (from
        the latest telemetry when no twin runs: on a short link that is now)."""
        checked = self.check("ptwl", desk.params("ptwl"))
        with self._lock:
            state = self._state
        point = self.twin.point if self.twin is not None else None
        note = "" if point is not None else "from the latest telemetry"
        if point is None and state is not None:
            point = point_from_state(state, self.task_frames)
        if not isinstance(checked.params, PtwlParams):
            desk.show_preview(None, f"no preview: {checked.errors}")
        elif point is None:
            desk.show_preview(None, "no preview: no robot state yet")
        else:
            desk.show_preview(self.previewer.run(point, checked.params), note)

    def send(self, desk: Desk, behavior: str, params: dict[str, Any]) -> None:
        """Send from a desk: only the one holding control; the record says who sent it."""
        assert self.view is not None
        if not self.seat.holds(desk.client_id):
            desk.client.add_notification(
                "Not sent: you are watching", "Take control to send commands.", color="red"
            )
            return
        sender = f"{desk.name} at console {self._host}:{self._front_port}"
        target = self._target_of(params) if behavior == "ptwl" else None  # Send step's: the step's
        view = self.history.sent(behavior, target, sender)
        if behavior == "ptwl":
            self._commanded = view  # shown at once, as predicted: intent does not wait for the link
        rtt_s = self.link_poller.rtt_s if self.link_poller is not None else 0.0
        max_age_s = rtt_s + self.defaults.max_age_over_rtt_s
        stamped = {"max_age": max_age_s, "sent_at": time.time(), **params}
        checked = self.check(behavior, stamped).params
        if self.twin is not None and isinstance(checked, BehaviorParams):  # the ghost moves at once
            sent_at = stamped["sent_at"]
            self.twin.on_sent(Sent(checked, sent_at, lambda: view.phase in ("sent", "queued")))
        self._submit(view, behavior, stamped, sender)

    def _target_of(self, params: dict[str, Any]) -> Pose | None:
        """Where a PTWL as sent goes from the port shown (None without a port, or in a frame not
        known yet): the commanded marker's place, from what is sent, not from the fields."""
        port = self._port()
        if port is None:
            return None
        try:
            return ptwl_target(
                port,
                np.asarray(params["translation"], dtype=float),
                np.asarray(params["rotation"], dtype=float),
                str(params["frame"]),
                self.task_frames,
            )
        except UnknownNameError:
            return None

    def _submit(self, view: CommandView, behavior: str, params: dict[str, Any], sender: str) -> None:
        self._after_change(view)
        try:
            accepted = self.client.command(behavior, sender=sender, **params)
        except RobotError as err:
            self.history.refused(view, str(err.detail))
            self._notify("Command refused", str(err.detail), "red")
        except httpx.HTTPError as err:
            self.history.refused(view, f"link: {type(err).__name__}")
            self._notify("Command not delivered", f"{type(err).__name__}: {err}", "red")
        else:
            self.history.accepted(view, accepted.id)
            for warning in accepted.warnings:
                self._notify(f"#{accepted.id}: check the approach", warning, "orange")
        self._after_change(view)

    def edit_frame(self, desk: Desk, name: str, pose: "dict[str, list[float]] | str | None") -> None:
        """Add a task frame at `pose` (`tool`, or a typed pose), or delete `name` (None); only the
        operator in control, as for commands. The robot's `frames` message follows for everyone."""
        if not self.seat.holds(desk.client_id):
            desk.client.add_notification(
                "Not done: you are watching", "Take control to edit frames.", color="red"
            )
            return
        try:
            changed = self.client.delete_frame(name) if pose is None else self.client.add_frame(name, pose)
        except (RobotError, httpx.HTTPError) as err:
            reason = str(err.detail) if isinstance(err, RobotError) else f"{type(err).__name__}: {err}"
            self._notify("Frame not changed", reason, "red")
            return
        with self._frames_lock:  # the robot's `frames` message may have come first: one entry a name
            heard = [f for f in self._frames_heard if f["name"] != changed.name]
            if pose is not None:
                heard.append(changed.model_dump())
            self._set_frames(heard)  # at once: the robot's message confirms it a downlink later

    def _set_frames(self, frames: list[dict[str, Any]]) -> None:
        """The robot's task frames, as now known: the checks, the twin and every desk use them."""
        with self._frames_lock:  # the feed's thread and a desk's click may both bring news
            if self._closed:
                return
            self._frames_heard = frames
            self.task_frames = frames_from_dicts(frames)
            if self.twin is not None:
                self.twin.frames = self.task_frames
            for desk in self.desks():
                desk.show_frames(frames)

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
        for view in self.history.stopped(result.aborted, result.dropped):
            self._after_change(view)
            self._announce_end(view)

    def reset_scene(self) -> None:
        """Reset the robot's scene; the bar says it is on its way until the new scene is drawn
        (a round trip for the reset, another for its geometry)."""
        assert self.board is not None
        seed = int(self.board.seed.value) or None
        scene = str(self.board.scene.value)
        self._scene_note = f"reset to {scene} sent at {time.strftime('%H:%M:%S')}, waiting for the robot"
        try:
            self.client.reset_scene(scene, seed)
            self._scene_note = f"drawing the {scene} scene"
            self._reload_geometry()
        except (RobotError, httpx.HTTPError) as err:
            self._scene_note = ""
            self._notify("Scene reset failed", str(err), "red")

    def _reload_geometry(self, geometry: GeometryModel | None = None) -> None:
        """The one path that (re)draws the scene's bodies: at start, after a reset, on a new scene."""
        assert self.view is not None
        geometry = geometry or self.client.geometry()
        self._set_frames([f.model_dump() for f in self.client.frames()])  # a replay's: as recorded
        with self.server.atomic():
            self.view.load(geometry)
            if self.ghost is not None:
                self.ghost.load(geometry)
        self.scene_name = geometry.scene
        self._scene_note = ""  # drawn: the bar's scene is the one in view
        self.history.set_scene(geometry.scene)  # the counts are per scene, as the paper's tables
        if self.board is not None:
            self._show_history()
        if self.board is not None:
            self.board.show_scene(geometry.scene)
        for desk in self.desks():
            desk.panel.show_scene_task(geometry.scene)

    def _reload_for_new_scene(self) -> None:
        """(its own thread) A scene loaded by someone else: draw it; a close meanwhile ends it."""
        try:
            self._reload_geometry()
        except (RobotError, httpx.HTTPError) as err:
            if not self._closed:
                self._notify("The new scene could not be drawn", f"{type(err).__name__}: {err}", "red")

    # ------------------------------------------------------------ telemetry
    def _on_state(self, state: dict[str, Any], arrived: float) -> None:
        assert self.board is not None and self.view is not None
        if self._closed:
            return
        with self._lock:
            previous = self._state
            self._state = state
            self._arrived = arrived
        self.telemetry_health.on_state(state["seq"], float(state["sent_at"]), arrived)
        if self.twin is not None:
            self.twin.on_state(state, arrived)
        self._check_instance(state["instance"])
        if previous is not None and state["seq"] > previous["seq"] + 1:
            self._reconcile_soon()  # messages were lost: an end event may be among them
        if state["scene"] != self.scene_name and self.handshake is not None and self.handshake.met:
            self.scene_name = state["scene"]
            self._scene_note = f"drawing the {state['scene']} scene"
            threading.Thread(target=self._reload_for_new_scene, daemon=True).start()
        if previous is None or state["gains"] != previous["gains"]:
            self.board.show_gains(state["gains"])
        with self.server.atomic():
            self.view.update(state)
            self.board.show_scene_state(state["seq"], arrived)
        for desk in self.desks():
            desk.update_contemplated()
        self._count += 1
        self.board.plots.add(state["sim_time"], state["wrench"])
        if self._count % PLOT_EVERY == 0:
            self.board.plots.refresh()

    def _on_command(self, message: dict[str, Any]) -> None:
        if self._closed:
            return
        self._check_instance(message["instance"])
        self._plot_event(message)
        if self.twin is not None:
            self.twin.on_command(message)
        view, ended = self.history.event(message)
        if view is None:
            return
        self._after_change(view)
        if ended:
            self._announce_end(view)

    def _plot_event(self, message: dict[str, Any]) -> None:
        """Mark starts and exits on the plots; draw the running command's thresholds."""
        if self.board is None or message.get("started_at") is None:
            return  # queued, or dropped before it ran
        plots = self.board.plots
        plots.mark()
        params = message.get("params") or {}
        running = message["status"] == "running" and "force_threshold" in params
        plots.set_thresholds((params["force_threshold"], params["torque_threshold"]) if running else None)

    def _after_change(self, view: CommandView) -> None:
        """Show a command's new state: its line, the history, and the commanded marker."""
        if view is self._commanded and self.view is not None and self.board is not None:
            live = view.phase != "done" and view.target is not None
            self.view.show_commanded(view.target if live else None, view.resolved)
            marker = self.view.commanded if view.resolved else self.view.predicted
            self.board.show_commanded(view, marker.distance_mm)
        self._show_command(view)

    def _announce_end(self, view: CommandView) -> None:
        said = (  # why an expired command never ran, what the monitor saw: that is what matters
            view.detail
            if view.exit in ("expired", "anomaly")
            else f"peak {view.peak_force or 0.0:.1f} N, {view.peak_torque or 0.0:.2f} N m"
        )
        title = f"{view.behavior.upper()} {view.label}: {view.exit}"
        self._notify(title, said, _notification_color(view.exit))

    def _check_instance(self, instance: str) -> None:
        """The robot restarted if its instance changed: say so, and show its cut-off commands lost."""
        lost = self.history.robot_instance(instance)
        if lost is None:
            return
        if any(v is self._commanded for v in lost):
            self._hide_commanded()
        labels = ", ".join(f"{v.behavior.upper()} {v.label}" for v in lost) or "none"
        self._notify("Robot restarted", f"commands it had not finished are lost: {labels}", "red")
        self._show_command(self.history.latest())
        # Last: the bar (its own thread) says "restarted" only once the command line says "lost".
        self._restart_note = f" · robot restarted at {time.strftime('%H:%M:%S')}"

    def _on_link(self, text: str) -> None:
        up = text == "connected"
        was_up, self._link_up = self._link_up, up
        self.telemetry_health.on_transport(up, text)
        if up and not was_up:
            self._reconcile_soon()  # whatever happened while we were away, the robot's records say

    def _on_link_profile(self, text: str) -> None:
        if self.board is not None:
            self.board.show_link_profile(text)

    def _replay_jumped(self) -> None:
        """A replay seek: the history and plots become what they were at the new time."""
        try:
            records = self.client.commands(limit=RECORDS_ON_RECONNECT)
        except (RobotError, httpx.HTTPError):
            return
        self.history.replace([r.model_dump() for r in records])
        self._commanded = None
        self._hide_commanded()
        if self.board is not None:
            self.board.plots.clear()
        self._show_command(self.history.latest())

    def _hide_commanded(self) -> None:
        """No commanded target on screen: its command is lost, or a replay left its time."""
        if self.view is not None and self.board is not None:
            self.view.show_commanded(None)
            self.board.show_commanded(None)

    def _reconcile_soon(self) -> None:
        """Re-read the robot's records in the background (at most one re-read at a time)."""
        if self._reconciling.acquire(blocking=False):
            threading.Thread(target=self._reconcile, name="ptwl-reconcile", daemon=True).start()

    def _reconcile(self) -> None:
        try:
            records = self.client.commands(limit=RECORDS_ON_RECONNECT)
        except (RobotError, httpx.HTTPError):
            return  # the next reconnect or gap tries again
        finally:
            self._reconciling.release()
        if self._closed:
            return
        for view in self.history.reconcile([r.model_dump() for r in records]):
            self._after_change(view)
            self._announce_end(view)
        if self._commanded is not None:
            self._after_change(self._commanded)
        self._show_command(self.history.latest())

    # -------------------------------------------------------------- display
    def _bar_inputs(self) -> BarInputs:
        with self._lock:
            state, arrived = self._state, self._arrived
        running = self.history.live()
        shown = running[0] if running else self.history.latest()
        command = f"{shown.behavior.upper()} {shown.label}: {shown.status}" if shown else "no command yet"
        if shown is not None and shown.sender:
            command += f" (by {shown.sender})"
        if len(running) > 1:
            command += f" · {len(running) - 1} more queued"
        rtt = self.link_poller.rtt_s if self.link_poller is not None else 0.0
        prediction = self._prediction
        trust, readout = twin_readout(time.time(), self.twin) if self.twin is not None else (None, "")
        return BarInputs(
            state,
            arrived,
            self._link_up,
            self.telemetry_health.line(rtt, time.time()),
            rtt,
            command,
            self._restart_note,
            scene_note=self._scene_note,
            stop=self.stopper.state,
            holder=operator_name(self.seat.holder) or "",
            predicted_port=tuple(prediction.port[0].tolist()) if prediction is not None else None,
            prediction_error=self.twin.error_summary() if self.twin is not None else None,
            twin_readout=readout,
            twin_sure=trust is not None and trust.sure,
            twin_note=self._twin_note(),
            recording=self._recording,
        )

    def _twin_note(self) -> str:
        worker = self.twin_worker
        if worker is None or not worker.idle:
            return ""
        return f"twin: idle while the round trip is under {worker.min_rtt_s:g} s (the picture is the present)"

    def _uplink_s(self) -> float:
        profile = self.link_poller.profile if self.link_poller is not None else None
        return float(profile["uplink"]) if profile is not None else 0.0

    def _on_prediction(self, prediction: Prediction | None) -> None:
        self._prediction = prediction

    def _on_tick(self, inputs: BarInputs) -> None:
        """(the bar's thread) The ghost's label from the same readout: the twin's own thread
        cannot say it lags while it lags."""
        if self.ghost is not None and inputs.predicted_port is not None:
            self.ghost.set_label(f"predicted · {inputs.twin_readout}")

    def _on_level(self, level: Level) -> None:
        if self.view is not None:
            silent_s = self.telemetry_health.silent_s(time.time())
            said = "link down" if not self._link_up else f"no telemetry for {silent_s or 0.0:.0f} s"
            self.view.set_stale(level == "stale", f"STALE: {said}")

    def _show_command(self, view: CommandView | None) -> None:
        if self.board is None:
            return
        self.board.show_command(view)
        self._show_history()

    def _show_history(self) -> None:
        assert self.board is not None
        scene = self.history.scene
        self.board.show_history(self.history.counts(scene), list(reversed(self.history.recent(8))), scene)

    def _notify(self, title: str, body: str, color: NotificationColor) -> None:
        for client in self.server.get_clients().values():
            client.add_notification(title, body, auto_close_seconds=6.0, color=color)

    def threads_running(self) -> list[str]:
        """The console's own threads still alive (all stop in close())."""
        parts = [
            ("handshake", self.handshake),
            ("status bar", self.bar),
            ("telemetry", self.feed),
            ("link poller", self.link_poller),
            ("twin", self.twin_worker),
        ]
        return [name for name, part in parts if part is not None and part.running]

    def close(self) -> None:
        self._closed = True
        for part in (
            self.handshake,
            self.bar,
            self.feed,
            self.link_poller,
            self.playback,
            self.twin_worker,
            self.stopper,
        ):
            if part is not None:
                part.close()
        # viser first, while the front door still carries its close handshake to the browsers:
        # closed the other way round, viser waited out its close timeout (6 s) on pipes nobody
        # read any more.
        self.server.stop()
        self.front_door.close()
        self.client.close()


def _notification_color(exit_condition: str | None) -> NotificationColor:
    colors: dict[str, NotificationColor] = {
        "goal_reached": "green",
        "completed": "green",
        "wrench_breach": "orange",
        "timeout": "yellow",
        "aborted": "gray",
        "expired": "blue",  # not a fault of the robot: the link held it too long
        "anomaly": "orange",  # the force task monitor stopped it: look before going on
    }
    return colors.get(exit_condition or "", "red")
