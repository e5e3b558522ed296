"""Every thread owned (issue 28.5): once the link proxy, the replay's stand-in and a console
watching a replay stop, `threading.enumerate()` holds no thread they started. (The robot server
in process: tests/test_routes_on_sim_thread.py; the console on a live robot:
tests/test_console_logic.py::test_close_stops_every_thread.)"""

import json
import re
import socket
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient
from websockets.utils import accept_key

from latency.link import Link
from latency.profile import LinkProfile
from latency.proxy import LinkProxy
from ptwl.experiments.sweep.spec import TrialSpec
from ptwl.experiments.sweep.trial import simulate
from ptwl.guard.access import AccessPolicy
from ptwl.launcher import free_port, running, running_server
from ptwl.recording.replay.player import Player
from ptwl.recording.replay.timeline import Timeline
from server.client import RobotClient
from server.replay.app import create_replay_app
from tests.helpers import threads_started_since
from web.app import ConsoleApp
from web.feed import CLOSE_TIMEOUT_S, RECEIVE_TIMEOUT_S, SCHEDULING_SLACK_S, TelemetryFeed


@contextmanager
def no_thread_left() -> Iterator[None]:
    before = set(threading.enumerate())
    yield
    deadline = time.monotonic() + 5.0  # a joined thread is gone; this is slack for the check only
    while True:
        left = threads_started_since(before)
        if not left or time.monotonic() > deadline:
            break
        time.sleep(0.05)
    assert left == []


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("threads") / "trial.mcap"
    simulate(TrialSpec("quick_connect", "onboard", 0.0, 0.0, 0.0, 0, think_s=0.0), record=path)
    return path


def test_the_link_proxy_in_process_leaves_no_thread_behind() -> None:
    with running_server("--scene", "free_space") as robot, no_thread_left():
        proxy = LinkProxy(robot.url, Link(LinkProfile(uplink=0.05)), AccessPolicy("127.0.0.1", 8001))
        with TestClient(proxy.app(), base_url="http://127.0.0.1:8001") as client:
            started = time.monotonic()
            assert client.get("/api/state").status_code == 200
            assert time.monotonic() - started >= 0.05  # through the delay line
            assert client.get("/_link/profile").json()["uplink"] == 0.05


def test_the_replay_stand_in_in_process_leaves_no_thread_behind(recording: Path) -> None:
    with no_thread_left():
        timeline = Timeline(recording)
        app = create_replay_app(
            timeline, Player(timeline.start_ns, timeline.end_ns), AccessPolicy("127.0.0.1", 8123)
        )
        with TestClient(app, base_url="http://127.0.0.1:8123") as client:
            assert client.put("/_replay", json={"playing": True}).json()["playing"]
            with client.websocket_connect("ws://127.0.0.1:8123/api/telemetry") as socket:
                assert socket.receive_json()["type"] == "frames"


def test_a_console_watching_a_replay_leaves_no_thread_behind(recording: Path) -> None:
    """Its playback poller and the thread that reads the recording for the timeline, besides
    the console's own (the feed, the status bar, viser's)."""
    with (
        running(
            "replay-serve", str(recording), "--port", str(free_port()), "--paused", health="/_replay"
        ) as robot,
        no_thread_left(),
    ):
        app = ConsoleApp(robot.url, port=free_port(), replay=True)
        app.connect(timeout=30.0)
        assert app.playback is not None
        deadline = time.monotonic() + 30.0
        while app.playback.record is None:  # the recording read and its commands marked
            assert time.monotonic() < deadline
            time.sleep(0.05)
        assert app.playback.running
        app.close()
        assert not app.playback.running


@contextmanager
def robot_that_never_answers_a_close() -> Iterator[str]:
    """A WebSocket peer at /api/telemetry that opens, sends one state, then reads and ignores
    everything: the close handshake never completes (a robot or link too busy to answer)."""
    listener = socket.create_server(("127.0.0.1", 0))
    held: list[socket.socket] = []

    def serve() -> None:
        conn, _ = listener.accept()
        held.append(conn)
        request = b""
        while b"\r\n\r\n" not in request:
            request += conn.recv(4096)
        key = re.search(rb"Sec-WebSocket-Key: *(\S+)", request, re.IGNORECASE)
        assert key is not None
        conn.sendall(
            b"HTTP/1.1 101 Switching Protocols\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
            b"Sec-WebSocket-Accept: " + accept_key(key.group(1).decode()).encode() + b"\r\n\r\n"
        )
        state = json.dumps({"type": "state", "seq": 1, "sent_at": time.time()}).encode()
        conn.sendall(bytes([0x81, len(state)]) + state)  # one unmasked text frame (< 126 bytes)
        while conn.recv(4096):
            pass

    server = threading.Thread(target=serve, name="test-silent-peer", daemon=True)
    server.start()
    try:
        yield f"http://127.0.0.1:{listener.getsockname()[1]}"
    finally:
        for conn in held:
            conn.close()
        listener.close()
        server.join(timeout=5.0)


def test_the_telemetry_feed_stops_within_its_join_though_the_far_end_never_answers_its_close() -> None:
    """websockets' default close_timeout (10 s) outlived the feed's join: the thread ran on after
    close(). The feed bounds the handshake (CLOSE_TIMEOUT_S) inside its join."""
    states: list[dict[str, Any]] = []
    with robot_that_never_answers_a_close() as url, RobotClient(url) as client:
        feed = TelemetryFeed(client, lambda s, _: states.append(s), print, lambda _: None, print)
        feed.start()
        deadline = time.monotonic() + 10.0
        while not states and time.monotonic() < deadline:
            time.sleep(0.02)
        assert states and states[0]["seq"] == 1
        started = time.monotonic()
        feed.close()
        took = time.monotonic() - started
        assert not feed.running, took
        # One receive timeout, then the close it waits out: at least the handshake's bound.
        assert CLOSE_TIMEOUT_S <= took <= RECEIVE_TIMEOUT_S + CLOSE_TIMEOUT_S + SCHEDULING_SLACK_S
