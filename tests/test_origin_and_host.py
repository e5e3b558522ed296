"""A web page the operator happens to visit must not reach the robot (issue 9, hole 1).

Each attack as a browser would make it: a foreign `Origin` on the WebSocket handshakes (robot
telemetry, the link's relay, the console's viser socket) and on a no-cors POST, and a DNS
rebinding name in `Host`. Scripts send no Origin and keep working.
"""

import asyncio
from collections.abc import Iterator

import httpx
import pytest
import viser
import websockets

from ptwl.guard.access import AccessPolicy
from ptwl.launcher import ServiceProcess, running_console, running_proxy, running_server
from server.client import RobotClient

EVIL = "http://evil.example:8000"


def ws_status(url: str, headers: dict[str, str] | None = None, subprotocols: list[str] | None = None) -> int:
    """101 if the handshake was accepted (and a first message arrived), else the HTTP status."""

    async def attempt() -> int:
        try:
            async with websockets.connect(
                url,
                additional_headers=headers,
                open_timeout=10,
                subprotocols=subprotocols,  # type: ignore[arg-type]
            ) as ws:
                await asyncio.wait_for(ws.recv(), 10.0)
                return 101
        except websockets.InvalidStatus as err:
            return err.response.status_code

    return asyncio.run(attempt())


@pytest.fixture(scope="module")
def stack() -> Iterator[tuple[ServiceProcess, ServiceProcess]]:
    with running_server("--scene", "free_space") as robot, running_proxy(robot.url) as link:
        yield robot, link


def busy(url: str) -> tuple[RobotClient, int]:
    client = RobotClient(url)
    client.reset_scene("free_space")
    return client, client.ptwl(translation=[0.0, 0.0, -0.02], duration=30.0).id


def test_policy_names_and_origins() -> None:
    policy = AccessPolicy("127.0.0.1", 8000, extra_origins=("https://ops.example:8443",))
    assert policy.host_problem("127.0.0.1:8000") is None and policy.host_problem("localhost") is None
    assert policy.host_problem("[::1]:8000") is None
    assert "evil.example" in (policy.host_problem("evil.example:8000") or "")
    assert policy.host_problem(None) == "missing Host header"
    assert policy.origin_problem(None) is None  # not a browser
    assert policy.origin_problem("http://127.0.0.1:8000") is None  # its own page
    assert policy.origin_problem("http://localhost:8000") is None
    assert policy.origin_problem("https://ops.example:8443") is None  # --allow-origin
    for foreign in (EVIL, "http://127.0.0.1:8080", "null", "http://127.0.0.1", "file://"):
        assert policy.origin_problem(foreign) is not None, foreign


def test_an_origin_without_a_port_has_its_schemes_default_port() -> None:
    """https://localhost is port 443 and http://localhost port 80: a server on one is not the
    origin of a page served on the other."""
    on_443, on_80 = AccessPolicy("127.0.0.1", 443), AccessPolicy("127.0.0.1", 80)
    assert on_443.origin_problem("https://localhost") is None
    assert on_443.origin_problem("http://localhost") is not None
    assert on_80.origin_problem("http://localhost") is None
    assert on_80.origin_problem("https://localhost") is not None
    assert on_80.origin_problem("http://localhost:99999") is not None  # no port at all


@pytest.mark.parametrize("through", ["robot", "link"])
def test_telemetry_socket_refuses_a_foreign_origin(stack: tuple[ServiceProcess, ...], through: str) -> None:
    base = stack[0].url if through == "robot" else stack[1].url
    url = base.replace("http://", "ws://") + "/api/telemetry"
    assert ws_status(url, {"Origin": EVIL}) == 403
    assert ws_status(url, {"Origin": "null"}) == 403
    assert ws_status(url) == 101  # a script (no Origin)
    assert ws_status(url, {"Origin": base}) == 101  # a page of the server's own origin


@pytest.mark.parametrize("through", ["robot", "link"])
@pytest.mark.parametrize("path", ["/api/stop", "/api/scene", "/api/commands", "/api/frames"])
def test_no_cors_post_from_another_origin_changes_nothing(
    stack: tuple[ServiceProcess, ...], through: str, path: str
) -> None:
    """What `fetch(url, {method: "POST", mode: "no-cors"})` sends: a text/plain body and Origin."""
    base = stack[0].url if through == "robot" else stack[1].url
    client, running = busy(base)
    bodies = {"/api/commands": '{"type": "rwe"}', "/api/frames": '{"name": "planted", "pose": "tool"}'}
    body = bodies.get(path, '{"name": "surface"}')
    response = httpx.post(base + path, content=body, headers={"Origin": EVIL, "Content-Type": "text/plain"})
    assert response.status_code == 403 and "evil.example" in response.json()["detail"]
    assert client.get(running).status == "running"
    assert client.health().queued == 0 and client.state().scene == "free_space"
    assert client.frames() == []  # no frame planted either
    client.stop()
    client.close()


@pytest.mark.parametrize("through", ["robot", "link"])
def test_dns_rebinding_host_is_refused(stack: tuple[ServiceProcess, ...], through: str) -> None:
    base = stack[0].url if through == "robot" else stack[1].url
    client, running = busy(base)
    port = base.rsplit(":", 1)[1]
    for method, path, body in (("POST", "/api/commands", {"type": "rwe"}), ("GET", "/api/state", None)):
        response = httpx.request(method, base + path, json=body, headers={"Host": f"evil.example:{port}"})
        assert response.status_code == 400 and "evil.example" in response.json()["detail"]
    url = base.replace("http://", "ws://") + "/api/telemetry"
    assert ws_status(url, {"Host": f"evil.example:{port}"}) == 400
    assert client.health().queued == 0 and client.get(running).status == "running"
    client.stop()
    client.close()


def test_allow_origin_and_allow_host_let_a_named_page_in() -> None:
    with running_server(
        "--scene", "free_space", "--allow-origin", "https://ops.example:8443", "--allow-host", "robot.example"
    ) as robot:
        url = robot.url.replace("http://", "ws://") + "/api/telemetry"
        assert ws_status(url, {"Origin": "https://ops.example:8443"}) == 101
        assert ws_status(url, {"Origin": "https://ops.example:9999"}) == 403
        port = robot.url.rsplit(":", 1)[1]
        assert (
            httpx.get(robot.url + "/api/health", headers={"Host": f"robot.example:{port}"}).status_code == 200
        )


def test_console_socket_refuses_a_foreign_origin(stack: tuple[ServiceProcess, ...]) -> None:
    """viser checks no Origin; the console's front door does, before viser sees a byte."""
    with running_console(stack[1].url) as console:
        ws = console.url.replace("http://", "ws://")
        viser_protocol = [f"viser-v{viser.__version__}"]
        assert ws_status(ws, {"Origin": EVIL}, viser_protocol) == 403
        assert ws_status(ws, {"Origin": console.url}, viser_protocol) == 101  # the console's own page
        port = console.url.rsplit(":", 1)[1]
        page = httpx.get(console.url + "/", headers={"Host": f"evil.example:{port}"})
        assert page.status_code == 400
        assert httpx.get(console.url + "/").status_code == 200  # the page itself still loads


def test_every_server_says_its_url_one_way_with_ipv6_in_brackets() -> None:
    """The robot, the link, the replay and the console print the URL they listen on through one
    function (the link's own copy printed http://::1:8001, which no client can open)."""
    from ptwl.guard.listen import bind, http_url, listening_url

    assert http_url("::1", 8001) == "http://[::1]:8001"
    assert http_url("127.0.0.1", 8000) == "http://127.0.0.1:8000"
    sock = bind("127.0.0.1", 0)
    try:
        assert listening_url(sock) == f"http://127.0.0.1:{sock.getsockname()[1]}"
    finally:
        sock.close()
