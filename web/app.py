"""The operator console: viser GUI + 3D scene, talking to the robot only through the link.

What the operator sees, after the teleoperation paper: intent at once (each browser's own
contemplated target while typing, the commanded target from Send), the robot as it reports itself
when that report arrives (with how old it is, counted on while nothing arrives), and each
command's life with its exit condition and who sent it. One browser holds control at a time.

`ConsoleApp` builds the rooms and wires them; each room has one job:
- `RobotLink` (web/robot_link.py): the connection, and what it last heard of the robot;
- `RobotView` (the 3D scene), `SceneKeeper` (which scene is drawn, resets);
- `CommandLog` (each command's life: history, command line, commanded marker, plot marks);
- `Commanding` (what desks do to the robot: check, preview, send, frames, STOP);
- `StatusRoom` + `StatusBar` (the pinned bar, drawn from one model a tick);
- `TwinRoom` (the predictive display); `Playback` (a replay's controls);
- `Board` (what every browser shares) and `Desk` (one per browser).
"""

from typing import Any

import viser

from robot_sim.task_frames import TaskFrames
from web.board import Board
from web.command_log import CommandLog
from web.commanding import Commanding
from web.defaults import load_defaults
from web.desks import Desks
from web.handshake import Catalog
from web.known_frames import KnownFrames
from web.playback import Playback
from web.replay_api import ReplayApi
from web.robot_link import RobotLink
from web.robot_view import RobotView
from web.scene_keeper import SceneKeeper
from web.seat import ControlSeat
from web.site import ConsoleSite
from web.status_room import StatusRoom
from web.twin_room import TwinRoom


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
        self.replay = replay  # the robot is `ptwl replay`'s stand-in for a recording
        catalog = Catalog.local()  # the console's own copy: Send shows without a round trip
        self.link = RobotLink(robot_url.rstrip("/"), token, catalog)
        defaults = load_defaults()
        self.site = ConsoleSite(host, port, allow_origins)
        server, notifier = self.site.viser, self.site.notifier
        seat = ControlSeat()
        self.playback: Playback | None = None  # when the robot is a recording
        view = RobotView(server, defaults.wrench_arrow_m_per_n)
        scene_names = [s.name for s in catalog.scenes]
        self.board = Board(server.gui, scene_names, scene_names[0], defaults.plot_s)
        self.log = CommandLog(self.link.client, self.board, view, notifier)
        self.frames = KnownFrames(self._frames_changed)
        self.commanding = Commanding(
            self.link, self.frames, self.log, seat, defaults, notifier, self.site.front_door.address
        )
        self.desks = Desks(catalog, defaults, seat, self.commanding, self.frames)
        self.scene = SceneKeeper(
            server, self.link, self.frames, view, self.board, self.log, notifier, self.desks.scene_drawn
        )
        self.twin_room: TwinRoom | None = None  # the predictive display (not for a recording)
        if defaults.twin and not replay:
            self.twin_room = TwinRoom(server, self.link, defaults.twin_min_rtt_s)
            self.commanding.twin = self.twin_room.twin
            self.scene.ghost = self.twin_room.ghost
        rooms = (self.link, self.log, self.commanding, seat, self.scene, self.twin_room, view)
        self.status = StatusRoom(server.gui, *rooms)

    @property
    def url(self) -> str:
        return self.site.url

    @property
    def server(self) -> viser.ViserServer:
        return self.site.viser

    @property
    def view(self) -> RobotView:
        return self.scene.view

    @property
    def seat(self) -> ControlSeat:
        return self.desks.seat

    @property
    def closed(self) -> bool:
        return self.log.closed

    # ---------------------------------------------------------------- start
    def connect(self, timeout: float | None = None) -> None:
        """Start the threads and meet the robot in the background (the panels and scene are up
        already); with `timeout`, wait that long for it (the scene drawn) or raise."""
        if self.replay:  # a replay's stand-in is local, never behind a link: asking costs nothing
            api = ReplayApi(self.link.robot_url, self.link.token)
            replay = api.get(timeout_s=5.0)
            if replay is None:
                api.close()
                raise RuntimeError(f"{self.link.robot_url} is not a replay (GET /_replay did not answer)")
            self.playback = Playback(
                self.server.gui,
                api,
                replay,
                self.log.replay_jumped,
                self.board.plots,
            )
            self.status.bar.stop.visible = False  # nothing moves on a recording
            self.status.recording = str(replay["file"]).rsplit("/", 1)[-1]
        self.status.bar.stop.on_click(lambda event: self.commanding.stop(event.client))
        self.board.reset_scene.on_click(lambda _: self.scene.reset())
        if self.playback is None:  # a replay is watched, not commanded: no form to send from
            self.server.on_client_connect(self.desks.connected)
            self.server.on_client_disconnect(self.desks.disconnected)
        # The meshes go out after the panels, when the robot has answered.
        self.link.start(
            self.scene.met_robot,
            self._on_state,
            self._on_command,
            self.frames.set,
            self.board.show_link_profile,
            self.log.reconcile_soon,
        )
        if self.twin_room is not None:
            self.twin_room.worker.start()
        self.status.bar.start()
        if self.playback is not None:
            self.playback.start()
        handshake = self.link.handshake
        if timeout is not None and handshake is not None and not handshake.wait(timeout):
            raise RuntimeError(f"robot at {self.link.robot_url} not reachable within {timeout:g} s")

    def _frames_changed(self, frames: list[dict[str, Any]], task_frames: TaskFrames) -> None:
        """The robot's task frames, as now known: the twin and every desk use them."""
        if self.twin_room is not None:
            self.twin_room.twin.frames = task_frames
        self.desks.frames_changed(frames, task_frames)

    # ------------------------------------------------------------ telemetry
    def _on_state(self, state: dict[str, Any], arrived: float, previous: dict[str, Any] | None) -> None:
        """(the feed's thread) A state: every view of the robot moves to it."""
        if self.closed:
            return
        if self.twin_room is not None:
            self.twin_room.twin.on_state(state, arrived)
        self.log.check_instance(state["instance"])
        if previous is not None and state["seq"] > previous["seq"] + 1:
            self.log.reconcile_soon()  # messages were lost: an end event may be among them
        self.scene.on_state_scene(state["scene"])
        if previous is None or state["gains"] != previous["gains"]:
            self.board.show_gains(state["gains"])
        with self.server.atomic():
            # The scene's mirror is sent with what moved, not again for a still scene (re-sent
            # with each state it cost every page ~50 layouts/s; the plots and bar still update).
            # The first state after a (re)load always moves: nothing was placed yet.
            if self.view.update(state):
                self.board.show_scene_state(state["seq"], arrived)
        self.desks.state_arrived()
        self.board.plot_state(state["sim_time"], state["wrench"])

    def _on_command(self, message: dict[str, Any]) -> None:
        if self.closed:
            return
        if self.twin_room is not None:
            self.twin_room.twin.on_command(message)
        self.log.on_command(message)

    # ----------------------------------------------------------------- end
    def threads_running(self) -> list[str]:
        """The console's own threads still alive (all stop in close())."""
        parts = [*self.link.threads(), ("status bar", self.status.bar)]
        if self.twin_room is not None:
            parts.append(("twin", self.twin_room.worker))
        return [name for name, part in parts if part is not None and part.running]

    def close(self) -> None:
        self.log.closed = self.scene.closed = True
        self.desks.close()
        self.link.close()
        for part in (
            self.status.bar,
            self.playback,
            self.twin_room.worker if self.twin_room is not None else None,
            self.commanding.stopper,
        ):
            if part is not None:
                part.close()
        for errands in (self.log.errands, self.scene.errands):
            errands.close()
        self.site.close()
        self.link.close_client()
