"""The telemetry feed: one background thread reading the robot's WebSocket through the link,
reconnecting by itself when the link or the robot goes away."""

import threading
import time
from collections.abc import Callable
from typing import Any

from server.client import RobotClient

RECONNECT_S = 1.0


class TelemetryFeed:
    def __init__(
        self,
        client: RobotClient,
        on_state: Callable[[dict[str, Any], float], None],
        on_command: Callable[[dict[str, Any]], None],
        on_link: Callable[[str], None],
    ) -> None:
        self._client = client
        self._on_state = on_state
        self._on_command = on_command
        self._on_link = on_link
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="ptwl-telemetry", daemon=True)
        self.connected = False
        self.reconnects = 0

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                for message in self._client.telemetry(open_timeout=5.0):
                    arrived = time.time()
                    if not self.connected:
                        self.connected = True
                        self._on_link("connected")
                    if message.get("type") == "state":
                        self._on_state(message, arrived)
                    elif message.get("type") == "command":
                        self._on_command(message)
                    if self._stop.is_set():
                        return
                reason = "the robot closed the telemetry stream"
            except Exception as err:  # any failure of the link: say so, then retry
                reason = f"{type(err).__name__}: {err}"[:160]
            if self.connected:
                self.reconnects += 1
            self.connected = False
            self._on_link(f"telemetry lost ({reason}); reconnecting")
            self._stop.wait(RECONNECT_S)
