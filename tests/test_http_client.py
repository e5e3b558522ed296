"""Our HTTP clients share one TLS context (ptwl/guard/client.py): httpx builds one per client,
reading the CA bundle each time (25-55 ms of CPU measured), for every robot client a script, the
console or a test makes."""

import ssl

import pytest

from ptwl.guard.client import tls_context
from server.client import RobotClient
from web.link_poller import LinkPoller
from web.replay_api import ReplayApi


def test_our_clients_read_the_ca_bundle_once_between_them(monkeypatch: pytest.MonkeyPatch) -> None:
    loads: list[object] = []
    original = ssl.SSLContext.load_verify_locations

    def counted(self: ssl.SSLContext, *args: object, **kwargs: object) -> None:
        loads.append(args or kwargs)
        original(self, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(ssl.SSLContext, "load_verify_locations", counted)
    tls_context.cache_clear()
    robots = [RobotClient("http://127.0.0.1:9", token=f"token-{i}-0123456789abcdef") for i in range(3)]
    poller = LinkPoller("http://127.0.0.1:9", None, lambda _text: None)
    replay = ReplayApi("http://127.0.0.1:9", None)
    try:
        assert len(loads) == 1, loads  # five clients, one context
        assert robots[2]._http.headers["authorization"] == "Bearer token-2-0123456789abcdef"
    finally:
        for robot in robots:
            robot.close()
        replay.close()
        poller.close()  # never started: closes its client
        tls_context.cache_clear()
