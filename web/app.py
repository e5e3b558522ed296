"""The operator console: viser GUI + 3D scene, talking to the robot only through the link.

What the operator sees, after the teleoperation paper: intent at once (the contemplated target
while typing, the commanded target from Send), the robot as it reports itself when that report
arrives (with how old it is), and each command's life with its exit condition.
"""

import threading
import time
from collections import deque
from typing import Any, Literal

import httpx
import numpy as np
import viser

from server.client import RobotClient, RobotError
from web.defaults import load_defaults
from web.feed import TelemetryFeed
from web.front_door import FrontDoor, admit_only_through
from web.history import CommandHistory, CommandView
from web.panel import Panel
from web.robot_view import RobotView
from web.targets import Pose, displacement_to, ptwl_target

NotificationColor = Literal["gray", "red", "green", "orange", "yellow", "blue"]
HTTP_TIMEOUT_S = 120.0  # requests cross the link twice; long delays are the point
PLOT_EVERY = 5  # telemetry messages per plot refresh (10 Hz at 50 Hz telemetry)


class ConsoleApp:
    def __init__(
        self,
        robot_url: str,
        host: str = "127.0.0.1",
        port: int = 8080,
        token: str | None = None,
        allow_origins: tuple[str, ...] = (),
    ):
        self.robot_url = robot_url.rstrip("/")
        self.token = token
        self.client = RobotClient(self.robot_url, token=token, timeout=HTTP_TIMEOUT_S)
        self.defaults = load_defaults()
        # viser checks no Origin: it listens on an ephemeral loopback port behind the front door.
        self.server = viser.ViserServer(host="127.0.0.1", port=0, label="ptwl console", verbose=False)
        self.front_door = FrontDoor(host, port, self.server.get_port(), allow_origins)
        admit_only_through(self.front_door, self.server)
        self._host = host
        self._front_port = self.front_door.start()
        # Looking at the workspace in front of the arm, from front-left and above.
        self.server.initial_camera.position = (1.05, -0.75, 0.75)
        self.server.initial_camera.look_at = (0.33, 0.0, 0.28)
        self.history = CommandHistory()
        self._lock = threading.Lock()
        self._state: dict[str, Any] | None = None
        self._last_seq: int | None = None
        self._last_arrival: float | None = None
        self._last_sent_at: float | None = None
        self._link_text = "connecting"
        self._restart_note = ""
        self._commanded: CommandView | None = None
        self._syncing_gizmo = False
        self._plot: deque[tuple[float, ...]] = deque()
        self._count = 0
        self.scene_name = ""
        self._closed = False
        self.panel: Panel | None = None
        self.view: RobotView | None = None
        self.feed: TelemetryFeed | None = None

    @property
    def url(self) -> str:
        shown = f"[{self._host}]" if ":" in self._host else self._host
        return f"http://{shown}:{self._front_port}"

    # ---------------------------------------------------------------- start
    def connect(self, timeout: float = 120.0) -> None:
        """Wait for the robot (through the link), then build the panel and the scene."""
        waiting = self.server.gui.add_markdown(f"Waiting for the robot at {self.robot_url} ...")
        deadline = time.monotonic() + timeout
        while True:
            try:
                presets = self.client.presets()
                scenes = [s.name for s in self.client.scenes()]
                geometry = self.client.geometry()
                break
            except (RobotError, httpx.HTTPError) as err:
                if time.monotonic() > deadline:
                    raise RuntimeError(f"robot at {self.robot_url} not reachable: {err}") from None
                time.sleep(1.0)
        waiting.remove()
        dither = presets.pop("dither")
        self.scene_name = geometry.scene
        self.view = RobotView(self.server, self.defaults.wrench_arrow_m_per_n)
        self.view.load(geometry)
        self.panel = Panel(self.server, self.defaults, list(presets), dither, scenes, geometry.scene)
        self.gizmo = self.server.scene.add_transform_controls("/gizmo", scale=0.08, visible=False)
        self._wire()
        self.feed = TelemetryFeed(self.client, self._on_state, self._on_command, self._on_link)
        self.feed.start()
        threading.Thread(target=self._poll_link_profile, name="ptwl-link-profile", daemon=True).start()

    def _wire(self) -> None:
        panel = self.panel
        assert panel is not None
        panel.send_ptwl.on_click(lambda _: self.send_ptwl())
        panel.send_rwe.on_click(lambda _: self._send("rwe", panel.rwe_params()))
        panel.send_dither.on_click(lambda _: self._send("dither", panel.dither_params()))
        panel.stop.on_click(lambda _: self.stop())
        panel.reset_scene.on_click(lambda _: self.reset_scene())
        for field in (panel.translation, panel.rotation, panel.frame):
            field.on_update(lambda _: self._fields_changed())
        panel.show_gizmo.on_update(lambda _: self._fields_changed())
        self.gizmo.on_update(lambda _: self._gizmo_moved())

    # ------------------------------------------------------------- commands
    def _port(self) -> Pose | None:
        with self._lock:
            state = self._state
        if state is None:
            return None
        return np.asarray(state["port"]["position"]), np.asarray(state["port"]["quaternion"])

    def send_ptwl(self) -> None:
        assert self.panel is not None and self.view is not None
        params = self.panel.ptwl_params()
        port = self._port()
        target = None
        if port is not None:
            target = ptwl_target(port, *self.panel.ptwl_values())
        view = self.history.sent("ptwl", target)
        self._commanded = view
        self.view.show_commanded(target)  # at once: intent does not wait for the link
        self._submit(view, "ptwl", params)

    def _send(self, behavior: str, params: dict[str, Any]) -> None:
        self._submit(self.history.sent(behavior), behavior, params)

    def _submit(self, view: CommandView, behavior: str, params: dict[str, Any]) -> None:
        assert self.panel is not None
        self.panel.show_command(view)
        self._show_history()
        try:
            accepted = self.client.command(behavior, **params)
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
        if view.phase == "done" and view is self._commanded and self.view is not None:
            self.view.show_commanded(None)
        self.panel.show_command(self.history.latest())
        self._show_history()

    def stop(self) -> None:
        try:
            result = self.client.stop()
            self._notify("Stopped", f"aborted {result.aborted}, dropped {len(result.dropped)} queued", "gray")
        except (RobotError, httpx.HTTPError) as err:
            self._notify("Stop not delivered", str(err), "red")

    def reset_scene(self) -> None:
        assert self.panel is not None
        seed = int(self.panel.seed.value) or None
        try:
            self.client.reset_scene(str(self.panel.scene.value), seed)
            self._reload_geometry()
        except (RobotError, httpx.HTTPError) as err:
            self._notify("Scene reset failed", str(err), "red")

    def _reload_geometry(self) -> None:
        assert self.view is not None
        geometry = self.client.geometry()
        with self.server.atomic():
            self.view.load(geometry)
        self.scene_name = geometry.scene

    # ------------------------------------------------------------ telemetry
    def _on_state(self, state: dict[str, Any], arrived: float) -> None:
        assert self.panel is not None and self.view is not None
        if self._closed:
            return
        with self._lock:
            self._state = state
            self._last_seq = state["seq"]
            self._last_arrival = arrived
            self._last_sent_at = state["sent_at"]
        self._check_instance(state["instance"])
        if state["scene"] != self.scene_name:
            self.scene_name = state["scene"]
            threading.Thread(target=self._reload_geometry, daemon=True).start()
        age = arrived - state["sent_at"]
        x, y, z = (1000.0 * v for v in state["port"]["position"])
        text = (
            f"robot state #{state['seq']} is <b>{age:.2f} s old</b> · port ({x:.1f}, {y:.1f}, {z:.1f}) mm"
            f" · {self._link_text}{self._restart_note}"
        )
        with self.server.atomic():
            self.view.update(state)
            self._update_contemplated()
            self.panel.show_status(text, state["seq"], arrived, age)
        self._count += 1
        self._plot.append((state["sim_time"], *state["wrench"]))
        while self._plot and self._plot[-1][0] - self._plot[0][0] > self.defaults.plot_s:
            self._plot.popleft()
        if self._count % PLOT_EVERY == 0:
            data = np.array(self._plot).T
            self.panel.force_plot.data = (data[0], data[1], data[2], data[3])
            self.panel.torque_plot.data = (data[0], data[4], data[5], data[6])

    def _on_command(self, message: dict[str, Any]) -> None:
        assert self.panel is not None
        if self._closed:
            return
        self._check_instance(message["instance"])
        view, ended = self.history.event(message)
        if view is None:
            return
        self.panel.show_command(view)
        self._show_history()
        if ended:
            if view is self._commanded and self.view is not None:
                self.view.show_commanded(None)  # the robot has reported it
            peak = f"peak {view.peak_force or 0.0:.1f} N, {view.peak_torque or 0.0:.2f} N m"
            self._notify(
                f"{view.behavior.upper()} {view.label}: {view.exit}", peak, _notification_color(view.exit)
            )

    def _check_instance(self, instance: str) -> None:
        """The robot restarted if its instance changed: say so, and show its cut-off commands lost."""
        assert self.panel is not None
        lost = self.history.robot_instance(instance)
        if lost is None:
            return
        self._restart_note = f" · <b>robot restarted</b> at {time.strftime('%H:%M:%S')}"
        if any(v is self._commanded for v in lost) and self.view is not None:
            self.view.show_commanded(None)
        labels = ", ".join(f"{v.behavior.upper()} {v.label}" for v in lost) or "none"
        self._notify("Robot restarted", f"commands it had not finished are lost: {labels}", "red")
        self.panel.show_command(self.history.latest())
        self._show_history()

    def _on_link(self, text: str) -> None:
        self._link_text = text
        if self.panel is not None and text != "connected":
            self.panel.show_status(f"<b>{text}</b>", None, None, None)

    def _poll_link_profile(self) -> None:
        assert self.panel is not None
        headers = {"Authorization": f"Bearer {self.token}"} if self.token else {}
        while True:
            try:
                response = httpx.get(self.robot_url + "/_link/profile", headers=headers, timeout=2.0)
                if response.status_code == 200:
                    p = response.json()
                    self.panel.link.content = (
                        f"link: uplink {p['uplink']:g} s · downlink {p['downlink']:g} s · "
                        f"round trip {p['uplink'] + p['downlink']:g} s (profile v{p['version']})"
                    )
                else:
                    self.panel.link.content = "link: direct connection (no link proxy)"
            except httpx.HTTPError as err:
                self.panel.link.content = f"link: control API unreachable ({type(err).__name__})"
            time.sleep(2.0)

    # -------------------------------------------------------- contemplated
    def _fields_changed(self) -> None:
        with self.server.atomic():
            self._update_contemplated(move_gizmo=True)

    def _update_contemplated(self, move_gizmo: bool = False) -> None:
        assert self.panel is not None and self.view is not None
        port = self._port()
        target = ptwl_target(port, *self.panel.ptwl_values()) if port is not None else None
        self.view.show_contemplated(target)
        show = bool(self.panel.show_gizmo.value) and target is not None
        appearing = show and not self.gizmo.visible
        self.gizmo.visible = show
        if show and target is not None and (move_gizmo or appearing):
            self._syncing_gizmo = True
            self.gizmo.position, self.gizmo.wxyz = target
            self._syncing_gizmo = False

    def _gizmo_moved(self) -> None:
        assert self.panel is not None
        port = self._port()
        if self._syncing_gizmo or port is None:
            return
        target = (np.asarray(self.gizmo.position), np.asarray(self.gizmo.wxyz))
        translation, rotation = displacement_to(port, target, str(self.panel.frame.value))
        self.panel.set_ptwl_displacement(translation, rotation)

    # -------------------------------------------------------------- display
    def _show_history(self) -> None:
        assert self.panel is not None
        counts = self.history.counts()
        ptwl = ", ".join(f"{k} {v}" for k, v in sorted(counts["ptwl"].items())) or "none"
        lines = [
            f"**PTWL** {counts['ptwl_total']} ({ptwl}) · **RWE** {counts['rwe']} · "
            f"**Dither** {counts['dither']}",
            f"peak force {counts['peak_force']:.1f} N · peak torque {counts['peak_torque']:.2f} N m",
            "",
            "| cmd | behavior | status | peak F [N] | peak τ [N m] | time [s] |",
            "|---|---|---|---|---|---|",
        ]
        for v in reversed(self.history.recent(8)):
            f = f"{v.peak_force:.1f}" if v.peak_force is not None else ""
            t = f"{v.peak_torque:.2f}" if v.peak_torque is not None else ""
            d = f"{v.duration:.2f}" if v.duration is not None else ""
            lines.append(f"| {v.label} | {v.behavior} | {v.status} | {f} | {t} | {d} |")
        self.panel.history.content = "\n".join(lines)

    def _notify(self, title: str, body: str, color: NotificationColor) -> None:
        for client in self.server.get_clients().values():
            client.add_notification(title, body, auto_close_seconds=6.0, color=color)

    def close(self) -> None:
        self._closed = True
        if self.feed is not None:
            self.feed.stop()
        self.front_door.close()
        self.server.stop()
        self.client.close()


def _notification_color(exit_condition: str | None) -> NotificationColor:
    colors: dict[str, NotificationColor] = {
        "goal_reached": "green",
        "completed": "green",
        "wrench_breach": "orange",
        "timeout": "yellow",
        "aborted": "gray",
    }
    return colors.get(exit_condition or "", "red")
