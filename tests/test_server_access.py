"""Access: loopback by default; a non-loopback bind needs a token; the token guards the API."""

import asyncio
import socket
from collections.abc import Iterator

import httpx
import pytest
import websockets

from ptwl.guard.access import AccessPolicy, check_token_setting
from ptwl.launcher import ServiceProcess, running_server
from server.config import ConfigError, ServerConfig, is_loopback
from tests.command_line import run_ptwl

TOKEN = "s3cret-token-0123456789"


@pytest.fixture(scope="module")
def guarded() -> Iterator[ServiceProcess]:
    with running_server("--scene", "free_space", "--token", TOKEN) as srv:
        yield srv


def test_default_bind_is_loopback() -> None:
    assert ServerConfig().host == "127.0.0.1"
    assert is_loopback("127.0.0.1") and is_loopback("::1") and is_loopback("localhost")
    assert not is_loopback("0.0.0.0") and not is_loopback("192.0.2.1")


def test_the_token_rule_at_its_edges_and_a_name_that_does_not_resolve() -> None:
    check_token_setting("x" * 16, "0.0.0.0")  # 16 characters: enough
    with pytest.raises(ConfigError, match="at least 16 characters"):
        check_token_setting("x" * 15, "0.0.0.0")
    assert not is_loopback("no-such-host.invalid")  # cannot be resolved: not known to be loopback
    with pytest.raises(ConfigError, match="needs an access token"):
        check_token_setting(None, "no-such-host.invalid")


def test_a_wildcard_bind_answers_to_the_machines_name_and_a_loopback_one_only_to_loopback() -> None:
    assert AccessPolicy("127.0.0.1", 8000).names == {"127.0.0.1", "localhost", "::1"}
    wildcard = AccessPolicy("0.0.0.0", 8000, TOKEN)
    assert wildcard.names == {"0.0.0.0", "127.0.0.1", "localhost", "::1", socket.gethostname().lower()}


def test_non_loopback_bind_without_token_refuses_to_start() -> None:
    with pytest.raises(ConfigError, match="needs an access token"):
        ServerConfig(host="0.0.0.0").check()
    result = run_ptwl("serve", "--host", "0.0.0.0", "--port", "0", env={"PATH": "/usr/bin:/bin"})
    assert result.returncode == 2
    assert "refusing to bind 0.0.0.0: a non-loopback address needs an access token" in result.stderr


@pytest.mark.parametrize(
    ("method", "path", "body"),
    [
        ("GET", "/api/state", None),
        ("POST", "/api/commands", {"type": "rwe"}),
        ("POST", "/api/stop", None),
        ("POST", "/api/scene", {"name": "surface"}),
        ("GET", "/api/commands", None),
        ("GET", "/api/frames", None),
        ("POST", "/api/frames", {"name": "guarded", "pose": "tool"}),
    ],
)
def test_token_required_401_missing_403_wrong(
    guarded: ServiceProcess, method: str, path: str, body: dict | None
) -> None:
    url = guarded.url + path
    missing = httpx.request(method, url, json=body)
    assert missing.status_code == 401 and "Bearer" in missing.json()["detail"]
    wrong = httpx.request(method, url, json=body, headers={"Authorization": "Bearer nope"})
    assert wrong.status_code == 403
    right = httpx.request(method, url, json=body, headers={"Authorization": f"Bearer {TOKEN}"})
    assert right.status_code in (200, 201, 202)


@pytest.mark.parametrize("path", ["/api/health", "/docs", "/openapi.json", "/redoc"])
def test_with_a_token_nothing_is_open_not_even_health_or_docs(guarded: ServiceProcess, path: str) -> None:
    assert httpx.get(guarded.url + path).status_code == 401
    right = httpx.get(guarded.url + path, headers={"Authorization": f"Bearer {TOKEN}"})
    assert right.status_code == 200


def test_websocket_needs_the_token_too(guarded: ServiceProcess) -> None:
    url = guarded.url.replace("http://", "ws://") + "/api/telemetry"

    async def status_of(target: str, headers: dict[str, str] | None = None) -> int:
        try:
            async with websockets.connect(target, additional_headers=headers, ping_interval=None) as ws:
                await asyncio.wait_for(ws.recv(), 2.0)
                return 101
        except websockets.InvalidStatus as err:
            return err.response.status_code

    assert asyncio.run(status_of(url)) == 401
    assert asyncio.run(status_of(url, {"Authorization": "Bearer nope"})) == 403
    assert asyncio.run(status_of(url, {"Authorization": f"Bearer {TOKEN}"})) == 101
    assert asyncio.run(status_of(url + f"?token={TOKEN}")) == 101  # browsers cannot set headers


@pytest.mark.parametrize("command", ["serve", "proxy"])
@pytest.mark.parametrize("token", [" ", "a", "short-token", "has white space in it"])
def test_a_weak_token_refuses_to_start(command: str, token: str) -> None:
    result = run_ptwl(command, "--port", "0", "--token", token)
    assert result.returncode == 2
    assert "access token must be at least 16 characters with no whitespace" in result.stderr


def test_a_token_in_the_query_string_opens_only_a_websocket() -> None:
    """Browsers cannot set headers on a WebSocket, so there `?token=` stands in for the bearer
    header; on plain HTTP it is refused (a URL with a secret ends up in logs and histories)."""
    from ptwl.guard.asgi import denial

    policy = AccessPolicy("0.0.0.0", 8000, "s3cret-token-of-enough-length", (), ())
    host = {"host": "0.0.0.0:8000"}
    assert denial(policy, host, "token=s3cret-token-of-enough-length", websocket=True) is None
    refused = denial(policy, host, "token=s3cret-token-of-enough-length", websocket=False)
    assert refused is not None and refused[0] == 401 and refused[2] == {"www-authenticate": "Bearer"}
    wrong = denial(policy, host, "token=guess", websocket=True)
    assert wrong is not None and wrong[0] == 403
    bearer = {**host, "authorization": "Bearer s3cret-token-of-enough-length"}
    assert denial(policy, bearer, "", websocket=False) is None
