"""The replay's playhead over HTTP (GET/PUT /_replay, server/replay/): what the console's
transport reads and changes. A live robot has no /_replay."""

from typing import Any

import httpx

from ptwl.guard.client import http_client


class ReplayApi:
    def __init__(self, robot_url: str, token: str | None) -> None:
        self._url = robot_url + "/_replay"
        # One client for the playhead's polls (4 a second): a bare `httpx.get` builds a new client
        # and TLS context each time.
        self._http = http_client(token)

    def close(self) -> None:
        self._http.close()

    def get(self, timeout_s: float = 2.0) -> dict[str, Any] | None:
        """The playhead; None if the replay did not answer (or the robot is not a replay)."""
        try:
            response = self._http.get(self._url, timeout=timeout_s)
        except httpx.HTTPError:
            return None
        return response.json() if response.status_code == 200 else None

    def put(self, **change: Any) -> dict[str, Any] | None:
        """The change made: the playhead as the replay answered (None if it did not)."""
        try:
            response = self._http.put(self._url, json=change, timeout=5.0)
        except httpx.HTTPError:
            return None
        return response.json() if response.status_code == 200 else None
