"""The open browsers' desks: one made for each browser that connects (none for a replay, which is
watched), gone when it leaves; told when control changes hands, the frames change or a new scene
is drawn; moved with each state."""

import threading
from collections.abc import Callable
from typing import Any

import viser

from robot_sim.task_frames import TaskFrames
from web.commanding import Commanding
from web.defaults import ConsoleDefaults
from web.desk import Desk, DeskCatalog
from web.handshake import Catalog
from web.known_frames import KnownFrames
from web.seat import ControlSeat, operator_name


class Desks:
    def __init__(
        self,
        catalog: Catalog,
        defaults: ConsoleDefaults,
        seat: ControlSeat,
        commanding: Commanding,
        frames: KnownFrames,
    ) -> None:
        presets = dict(catalog.presets)
        dither = presets.pop("dither")
        tasks = {t.name: t.summary for t in catalog.tasks}
        self._catalog = DeskCatalog(defaults, presets, dither, tasks)
        self.seat, self._commanding, self._frames = seat, commanding, frames
        self._lock = threading.Lock()
        self._desks: dict[int, Desk] = {}
        self.scene = ""  # the scene drawn: each new desk picks its task
        self.closed = False
        seat.on_change(self._seat_changed)

    def connected(self, client: viser.ClientHandle) -> None:
        if self.closed:
            return
        desk = Desk(client, self._catalog, self.seat, self._commanding)
        desk.panel.show_scene_task(self.scene)
        desk.show_frames(self._frames.heard())
        with self._lock:
            self._desks[client.client_id] = desk

    def disconnected(self, client: viser.ClientHandle) -> None:
        with self._lock:
            self._desks.pop(client.client_id, None)
        self.seat.release(client.client_id)

    def all(self) -> list[Desk]:
        with self._lock:
            return list(self._desks.values())

    def _each(self, tell: Callable[[Desk], None]) -> None:
        """Tell every desk; one whose browser has just gone (viser removed its handles before
        its disconnect callback came) is forgotten, and the others are still told."""
        for desk in self.all():
            try:
                tell(desk)
            except RuntimeError:  # "Cannot assign to ... on a removed ...Handle"
                with self._lock:
                    self._desks.pop(desk.client_id, None)

    def _seat_changed(self, previous: int | None, new: int | None) -> None:
        def tell(desk: Desk) -> None:
            desk.seat_changed()
            if desk.client_id == previous and new is not None:
                desk.client.add_notification(
                    "Control taken",
                    f"{operator_name(new)} has control now; you are watching.",
                    color="orange",
                )

        self._each(tell)

    def frames_changed(self, frames: list[dict[str, Any]], _: TaskFrames) -> None:
        if not self.closed:
            self._each(lambda desk: desk.show_frames(frames))

    def scene_drawn(self, scene: str) -> None:
        self.scene = scene

        def tell(desk: Desk) -> None:
            desk.panel.show_scene_task(scene)
            desk.preview.clear()  # of the scene before

        self._each(tell)

    def state_arrived(self) -> None:
        """The port moved: each desk's contemplated target moves with it."""
        self._each(Desk.state_arrived)

    def close(self) -> None:
        """No new desk, and every desk's preview joined."""
        self.closed = True
        self._each(Desk.close_previews)
