"""The console's connection to the robot, through the link: its HTTP client, the telemetry feed,
the link's profile and the first handshake; and what it last heard (the latest state and when it
arrived, whether the transport is up, the telemetry's health). Everything else reads the robot
from here."""

import threading
from collections.abc import Callable
from typing import Any

import numpy as np

from robot_sim.behaviors.base import PoseArrays
from server.client import RobotClient
from server.models import GeometryModel
from web.feed import TelemetryFeed
from web.handshake import Catalog, Handshake
from web.link_poller import LinkPoller
from web.telemetry_health import TelemetryHealth

HTTP_TIMEOUT_S = 120.0  # requests cross the link twice; long delays are the point
StateFn = Callable[[dict[str, Any], float, "dict[str, Any] | None"], None]  # state, arrival, previous


class RobotLink:
    def __init__(self, robot_url: str, token: str | None, local: Catalog) -> None:
        self.robot_url, self.token = robot_url, token
        self._local = local  # what this console knows (scenes, presets): the handshake compares
        self.client = RobotClient(robot_url, token=token, timeout=HTTP_TIMEOUT_S)
        self.health = TelemetryHealth()
        self._lock = threading.Lock()
        self._state: dict[str, Any] | None = None
        self._arrived: float | None = None
        self.link_up = False
        self.handshake: Handshake | None = None
        self.feed: TelemetryFeed | None = None
        self.poller: LinkPoller | None = None

    def start(
        self,
        on_met: Callable[[GeometryModel, list[str]], None],
        on_state: StateFn,
        on_command: Callable[[dict[str, Any]], None],
        on_frames: Callable[[list[dict[str, Any]]], None],
        on_profile: Callable[[str], None],
        on_reconnected: Callable[[], None],
    ) -> None:
        """Meet the robot (in the background) and start listening."""

        def state(message: dict[str, Any], arrived: float) -> None:
            with self._lock:
                previous, self._state, self._arrived = self._state, message, arrived
            self.health.on_state(
                message["seq"],
                float(message["sent_at"]),
                arrived,
                int(message.get("skipped", 0)),
                float(message["every_s"]) if "every_s" in message else None,
                self.poller is not None and self.poller.replaces_states,
            )
            on_state(message, arrived, previous)

        def link(text: str) -> None:
            up = text == "connected"
            was_up, self.link_up = self.link_up, up
            self.health.on_transport(up, text)
            if up and not was_up:
                on_reconnected()  # whatever happened while we were away, the robot's records say

        self.handshake = Handshake(self.client, self._local, on_met)
        self.handshake.start()
        self.feed = TelemetryFeed(self.client, state, on_command, link, on_frames)
        self.poller = LinkPoller(self.robot_url, self.token, on_profile)
        self.feed.start()
        self.poller.start()

    def latest(self) -> tuple[dict[str, Any] | None, float | None]:
        """(the latest state, [s] Unix time it arrived)."""
        with self._lock:
            return self._state, self._arrived

    def port(self) -> PoseArrays | None:
        state, _ = self.latest()
        if state is None:
            return None
        return np.asarray(state["port"]["position"]), np.asarray(state["port"]["quaternion"])

    @property
    def met(self) -> bool:
        return self.handshake is not None and self.handshake.met

    def rtt_s(self) -> float:
        """[s] the link's configured round trip (0 without a link)."""
        return self.poller.rtt_s if self.poller is not None else 0.0

    def outlook(self) -> dict[str, Any] | None:
        """The link's schedule now and next (latency/outlook.py) on this console's clock; None
        without a link proxy."""
        return self.poller.outlook if self.poller is not None else None

    def profile(self) -> dict[str, Any] | None:
        return self.poller.profile if self.poller is not None else None

    def uplink_s(self) -> float:
        profile = self.poller.profile if self.poller is not None else None
        return float(profile["uplink"]) if profile is not None else 0.0

    def threads(self) -> list[tuple[str, Any]]:
        return [("handshake", self.handshake), ("telemetry", self.feed), ("link poller", self.poller)]

    def close(self) -> None:
        for _, part in self.threads():
            if part is not None:
                part.close()

    def close_client(self) -> None:
        self.client.close()
