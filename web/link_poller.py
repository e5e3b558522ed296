"""The link's own profile and outlook (GET /_link/profile and /_link/outlook, local to the proxy
and never delayed), polled so the console knows the round trip it is working across and the
schedule it plans around; stoppable."""

import time
from collections.abc import Callable
from typing import Any

import httpx

from ptwl.guard.client import http_client
from web.link_plan import link_replaces_states
from web.worker import Worker

POLL_S = 2.0
UNIX_FIELDS = ("changes_at_unix", "closed_since_unix")


def on_local_clock(outlook: dict[str, Any], local_now: float) -> dict[str, Any]:
    """The outlook with its Unix times moved to this console's clock (the proxy's may differ;
    the control API answers at once, so its `now_unix` is our `local_now`)."""
    shift = local_now - float(outlook["now_unix"])
    moved: dict[str, Any] = {"now_unix": local_now}
    for direction in ("uplink", "downlink"):
        d = dict(outlook[direction])
        for name in UNIX_FIELDS:
            if d.get(name) is not None:
                d[name] = float(d[name]) + shift
        moved[direction] = d
    return moved


class LinkPoller(Worker):
    def __init__(self, robot_url: str, token: str | None, on_text: Callable[[str], None]) -> None:
        self._url = robot_url + "/_link/profile"
        self._outlook_url = robot_url + "/_link/outlook"
        # One client for every poll: a bare `httpx.get` builds a new client and TLS context each
        # time, which was ~7% of an idle console's CPU (py-spy) at one poll every 2 s.
        self._http = http_client(token, timeout=2.0)
        self._on_text = on_text
        self.rtt_s = 0.0
        self.profile: dict[str, Any] | None = None
        self.outlook: dict[str, Any] | None = None  # the link's now and next, on this console's clock
        self.replaces_states = False  # judged once a poll, read on every state (web/link_plan.py)
        super().__init__("ptwl-link-profile", join_timeout_s=POLL_S + 1.0)

    def _run(self) -> None:
        while not self._closed.is_set():
            self._on_text(self.poll())
            self._closed.wait(POLL_S)

    def close(self) -> None:
        super().close()  # the thread has stopped polling (joined) before its client closes
        self._http.close()

    def _poll_outlook(self) -> dict[str, Any] | None:
        """The link's now and next, on this console's clock (None: a link that does not say)."""
        try:
            response = self._http.get(self._outlook_url)
        except httpx.HTTPError:
            return None
        return on_local_clock(response.json(), time.time()) if response.status_code == 200 else None

    def poll(self) -> str:
        try:
            response = self._http.get(self._url)
        except httpx.HTTPError as err:
            return f"link: its control API does not answer ({type(err).__name__})"
        if response.status_code != 200:
            self.profile, self.outlook, self.rtt_s = None, None, 0.0
            self.replaces_states = False
            return "link: direct connection (no link proxy)"
        p = self.profile = response.json()
        self.replaces_states = link_replaces_states(p)
        self.outlook = self._poll_outlook()
        self.rtt_s = float(p["uplink"]) + float(p["downlink"])
        described = f": {p['description']}" if p.get("description") else ""
        return (
            f"link: uplink {p['uplink']:g} s · downlink {p['downlink']:g} s · "
            f"round trip {self.rtt_s:g} s (profile v{p['version']}{described})"
        )
