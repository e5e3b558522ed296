"""The console's web surface opens in the order that cannot collide with itself."""

import socket

import httpx
import pytest
import viser

import web.site
from ptwl.launcher import free_port
from web.front_door import FrontDoor
from web.site import ConsoleSite


def test_the_front_door_holds_its_port_before_viser_takes_an_ephemeral_one(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A CI run's console was refused its own port: viser, started first on port 0, had been given
    the very port the launcher had just probed free for the front door (35815 both)."""
    port = free_port()
    held_when_viser_started: list[bool] = []
    real_viser = viser.ViserServer

    def viser_after_the_front_door(**kwargs: object) -> viser.ViserServer:
        with socket.socket() as probe:  # the port the front door asked for is taken by then
            held_when_viser_started.append(probe.connect_ex(("127.0.0.1", port)) == 0)
        return real_viser(**kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(web.site.viser, "ViserServer", viser_after_the_front_door)
    site = ConsoleSite("127.0.0.1", port, ())
    try:
        assert held_when_viser_started == [True]
        assert site.front_door.inner_port == site.viser.get_port() != port
        assert httpx.get(site.url + "/", timeout=10.0).status_code == 200  # and wired to viser
    finally:
        site.close()


def test_a_front_door_with_no_viser_yet_says_the_console_is_not_ready() -> None:
    door = FrontDoor("127.0.0.1", 0)
    port = door.start()
    try:
        answer = httpx.get(f"http://127.0.0.1:{port}/", timeout=10.0)
        assert (answer.status_code, answer.json()) == (503, {"detail": "console not ready"})
    finally:
        door.close()
