"""Which scene is in view: drawn when the robot is first met, after a reset from this console,
and when telemetry names a scene someone else loaded; until it is drawn, the status bar says a
reset is on its way or a scene is being drawn (`note`)."""

import time
from collections.abc import Callable

import httpx
import viser

from server.client import RobotError
from server.models import GeometryModel
from web.board import Board
from web.command_log import CommandLog
from web.errands import Errands
from web.ghost import GhostView
from web.known_frames import KnownFrames
from web.notifier import Notifier
from web.robot_link import RobotLink
from web.robot_view import RobotView


class SceneKeeper:
    def __init__(
        self,
        server: viser.ViserServer,
        link: RobotLink,
        frames: KnownFrames,
        view: RobotView,
        board: Board,
        log: CommandLog,
        notifier: Notifier,
        on_drawn: Callable[[str], None],  # the scene now in view (each desk picks its task)
    ) -> None:
        self._server, self._link, self._frames, self.view = server, link, frames, view
        self._board, self._log, self._notifier, self._on_drawn = board, log, notifier, on_drawn
        self.ghost: GhostView | None = None  # drawn with the scene, when the twin runs
        self.name = ""
        self.note = ""  # a reset on its way, or a new scene not drawn yet
        self.closed = False
        self.errands = Errands()

    def met_robot(self, geometry: GeometryModel, differences: list[str]) -> None:
        """(handshake thread) The robot answered: draw its scene; say if its catalog differs."""
        if self.closed:
            return
        self.draw(geometry)
        if differences:
            self._notifier.notify(
                "This console is not the robot's version",
                f"the robot's {', '.join(differences)} differ from what this console shows; "
                "commands are checked by the robot, which names anything it does not know",
                "orange",
            )

    def reset(self) -> None:
        """Reset the robot's scene; the bar says it is on its way until the new scene is drawn
        (a round trip for the reset, another for its geometry)."""
        seed = int(self._board.seed.value) or None
        scene = str(self._board.scene.value)
        self.note = f"reset to {scene} sent at {time.strftime('%H:%M:%S')}, waiting for the robot"
        try:
            self._link.client.reset_scene(scene, seed)
            self.note = f"drawing the {scene} scene"
            self.draw()
        except (RobotError, httpx.HTTPError) as err:
            self.note = ""
            self._notifier.notify("Scene reset failed", str(err), "red")

    def on_state_scene(self, scene: str) -> None:
        """A state names its scene: one loaded by someone else is drawn (on its own thread)."""
        if scene == self.name or not self._link.met:
            return
        self.name = scene
        self.note = f"drawing the {scene} scene"
        self.errands.run("ptwl-draw-scene", self._draw_new)

    def draw(self, geometry: GeometryModel | None = None) -> None:
        """The one path that (re)draws the scene's bodies: at start, after a reset, on a new scene."""
        client = self._link.client
        geometry = geometry or client.geometry()
        self._frames.set([f.model_dump() for f in client.frames()])  # a replay's: as recorded
        with self._server.atomic():
            self.view.load(geometry)
            if self.ghost is not None:
                self.ghost.load(geometry)
        self.name = geometry.scene
        self.note = ""  # drawn: the bar's scene is the one in view
        self._log.set_scene(geometry.scene)
        self._board.show_scene(geometry.scene)
        self._on_drawn(geometry.scene)

    def _draw_new(self) -> None:
        """(its own thread) A scene loaded by someone else: draw it; a close meanwhile ends it."""
        try:
            self.draw()
        except (RobotError, httpx.HTTPError) as err:
            if not self.closed:
                self._notifier.notify(
                    "The new scene could not be drawn", f"{type(err).__name__}: {err}", "red"
                )
