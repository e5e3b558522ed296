"""Meeting the robot without making the operator wait for it.

The console builds its panels from its own copy of the robot's catalog (server/catalog.py: the
presets, scenes and tasks, from the same configuration the robot loads), so Send shows as soon
as a browser has built the page. This thread meanwhile asks the robot, through the link and
all at once (one round trip), for its catalog and its scene's geometry; it reports what
differs (a robot of another version) and hands the geometry over to be drawn. Until the robot
answers it asks again every second; it is stopped by `close()`.
"""

import json
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import httpx

from server.catalog import preset_catalog, scene_catalog, task_catalog
from server.client import RobotClient, RobotError
from server.models import GeometryModel, SceneModel, TaskInfoModel
from web.worker import Worker

RETRY_S = 1.0


@dataclass(frozen=True)
class Catalog:
    presets: dict[str, Any]  # GET /api/presets: stiffness presets by name, dither ones under "dither"
    scenes: list[SceneModel]
    tasks: list[TaskInfoModel]

    @staticmethod
    def local() -> "Catalog":
        return Catalog(json.loads(json.dumps(preset_catalog())), scene_catalog(), task_catalog())

    def differences(self, other: "Catalog") -> list[str]:
        """What the robot offers that this console does not show the same way."""
        differ = []
        if self.presets != other.presets:
            differ.append("presets")
        if self.scenes != other.scenes:
            differ.append("scenes")
        if [(t.name, t.summary, t.settings) for t in self.tasks] != [
            (t.name, t.summary, t.settings) for t in other.tasks
        ]:
            differ.append("tasks")
        return differ


class Handshake(Worker):
    def __init__(
        self, client: RobotClient, local: Catalog, on_met: Callable[[GeometryModel, list[str]], None]
    ) -> None:
        self._client = client
        self._local = local
        self._on_met = on_met
        self.met = False
        super().__init__("ptwl-handshake", join_timeout_s=RETRY_S + 2.0)

    def wait(self, timeout_s: float) -> bool:
        """Wait until the robot has answered and been taken in; whether it has."""
        self._thread.join(timeout_s)
        return self.met and not self._thread.is_alive()

    def _run(self) -> None:
        with ThreadPoolExecutor(4, thread_name_prefix="ptwl-handshake") as pool:
            while not self._closed.is_set():
                presets = pool.submit(self._client.presets)
                scenes = pool.submit(self._client.scenes)
                tasks = pool.submit(self._client.tasks)
                geometry = pool.submit(self._client.geometry)
                try:
                    robot = Catalog(presets.result(), scenes.result(), tasks.result())
                    drawn = geometry.result()
                except (RobotError, httpx.HTTPError):
                    self._closed.wait(RETRY_S)
                    continue
                self.met = True
                self._on_met(drawn, self._local.differences(robot))
                return
