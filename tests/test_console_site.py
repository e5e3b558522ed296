"""The console's web surface opens in the order that cannot collide with itself, and its front
door leaves nothing behind: not a thread when its bind is refused, not a connection when closed."""

import socket
import threading

import httpx
import pytest
import viser

import web.site
from web.front_door import FrontDoor
from web.site import ConsoleSite


def _front_door_threads() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name == "ptwl-front-door"]


def test_the_front_door_holds_its_port_before_viser_takes_an_ephemeral_one(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A CI run's console was refused its own port: viser, started first on port 0, had been given
    the very port the launcher had just probed free for the front door (35815 both)."""
    doors: list[FrontDoor] = []
    held_when_viser_started: list[bool] = []
    real_front_door, real_viser = web.site.FrontDoor, viser.ViserServer

    def front_door(*args: object) -> FrontDoor:
        doors.append(real_front_door(*args))  # type: ignore[arg-type]
        return doors[-1]

    def viser_after_the_front_door(**kwargs: object) -> viser.ViserServer:
        with socket.socket() as probe:  # the front door listens by then
            bound = doors[0].port_bound if doors else None
            held_when_viser_started.append(bound is not None and probe.connect_ex(("127.0.0.1", bound)) == 0)
        return real_viser(**kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(web.site, "FrontDoor", front_door)
    monkeypatch.setattr(web.site.viser, "ViserServer", viser_after_the_front_door)
    site = ConsoleSite("127.0.0.1", 0, ())
    try:
        assert held_when_viser_started == [True]
        assert site.front_door.inner_port == site.viser.get_port()
        assert httpx.get(site.url + "/", timeout=10.0).status_code == 200  # and wired to viser
    finally:
        site.close()


def test_only_the_front_doors_url_is_printed_not_visers_inner_one(capsys: pytest.CaptureFixture[str]) -> None:
    """viser prints a box with its own URL; that port refuses browsers (not through the front
    door), so a user who opened it would find a console that never connects."""
    site = ConsoleSite("127.0.0.1", 0, ())
    try:
        printed = capsys.readouterr().out
        assert f":{site.viser.get_port()}" not in printed and "Websocket" not in printed, printed
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


def test_a_refused_bind_raises_and_leaves_no_thread_running() -> None:
    before = len(_front_door_threads())
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        with pytest.raises(OSError, match="address already in use"):
            FrontDoor("127.0.0.1", taken.getsockname()[1]).start()
    assert len(_front_door_threads()) == before


def test_closing_ends_the_connections_it_carries_and_joins_its_thread() -> None:
    """A browser connected through the front door to a console that says nothing yet: closing the
    front door closes the browser's socket (it reads the end) and its thread ends."""
    with socket.socket() as console:  # accepts, then never answers
        console.bind(("127.0.0.1", 0))
        console.listen()
        door = FrontDoor("127.0.0.1", 0)
        port = door.start()
        door.inner_port = console.getsockname()[1]
        with (
            socket.create_connection(("127.0.0.1", port), timeout=10.0) as browser,
            socket.create_connection(("127.0.0.1", port), timeout=10.0) as silent,  # no head yet
        ):
            browser.sendall(f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n".encode())
            inner, _ = console.accept()  # the front door passed it on
            with inner:
                assert inner.recv(4096).startswith(b"GET / HTTP/1.1")
                door.close()
                assert browser.recv(4096) == b""  # closed by the front door, not left hanging
                assert silent.recv(4096) == b""  # and one still sending its head
                inner.settimeout(10.0)
                assert inner.recv(4096) == b""  # and viser's end of the pipe
    assert not door._thread.is_alive() and door._loop.is_closed()
