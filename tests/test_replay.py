"""`ptwl replay`: the playhead (exact, on a fake clock), the recording served as the robot (the
state, scene and commands as they were at the playhead; nothing can be sent), its telemetry
socket in recorded order, and the console on it in a real browser (play, pause, seek)."""

import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import httpx
import pytest
from fastapi.testclient import TestClient

from ptwl.experiments.sweep.spec import TrialSpec
from ptwl.experiments.sweep.trial import simulate
from ptwl.guard.access import AccessPolicy
from ptwl.launcher import free_port, running
from ptwl.recording.reader import read
from ptwl.recording.replay.player import Player
from ptwl.recording.replay.timeline import Timeline
from server.replay import app as replay_app
from server.replay.app import create_replay_app
from tests.console_page import port_mm, until
from tests.fake_clock import FakeClock

SPEC = TrialSpec("quick_connect", "onboard", 0.0, 0.0, 0.0, 0, think_s=0.0)


@pytest.fixture(scope="module")
def recording_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("replay") / "trial.mcap"
    simulate(SPEC, record=path)
    return path


@pytest.fixture(scope="module")
def timeline(recording_path: Path) -> Timeline:
    return Timeline(recording_path)


def test_the_playhead_moves_at_speed_from_where_it_was_set_and_stops_at_the_end() -> None:
    clock = FakeClock()
    player = Player(0, 10_000_000_000, clock)
    assert player.now().position_ns == 0 and not player.now().playing
    player.set(playing=True, speed=2.0)
    clock.now += 1.5
    assert player.now().position_ns == 3_000_000_000
    player.set(speed=0.5)  # a speed change keeps the position
    clock.now += 2.0
    assert player.now().position_ns == 4_000_000_000
    player.set(playing=False)
    clock.now += 5.0
    assert player.now().position_ns == 4_000_000_000  # paused: still
    player.set(position_ns=9_000_000_000, playing=True)
    assert player.jumps == 1
    clock.now += 10.0
    head = player.now()
    assert head.position_ns == 10_000_000_000 and not head.playing  # the end: stopped there
    player.set(playing=True)  # play at the end starts over
    assert player.now().position_ns == 0 and player.jumps == 2
    player.set(position_ns=-5)
    assert player.now().position_ns == 0  # clamped


def _client(timeline: Timeline, clock: Callable[[], float] = time.monotonic) -> tuple[TestClient, Player]:
    player = Player(timeline.start_ns, timeline.end_ns, clock)
    app = create_replay_app(timeline, player, AccessPolicy("127.0.0.1", 8123))
    return TestClient(app, base_url="http://127.0.0.1:8123"), player


def test_the_robot_as_it_was_at_the_playhead(timeline: Timeline, recording_path: Path) -> None:
    client, _ = _client(timeline)
    rec = read(recording_path)
    events = rec.on("/commands")
    queued_ns, running_ns, done_ns = (
        next(m.log_time_ns for m in events if m.value["status"] == s) for s in ("queued", "running", "done")
    )
    assert queued_ns <= running_ns < done_ns

    def at(ns: int) -> dict[str, Any]:
        response = client.put("/_replay", json={"position_s": (ns - timeline.start_ns) / 1e9})
        assert response.status_code == 200
        return response.json()

    at(timeline.start_ns)
    assert client.get("/api/commands").json() == [] or queued_ns == timeline.start_ns
    at(running_ns + 10_000_000)
    [command] = client.get("/api/commands").json()
    assert (command["status"], command["type"], command["exit"]) == ("running", "state_machine", None)
    state = client.get("/api/state").json()
    telemetry = rec.on("/ptwl/telemetry")
    expected = [m.value for m in telemetry if m.log_time_ns <= running_ns + 10_000_000][-1]
    assert state["sim_time"] == expected["sim_time"] and state["port"] == expected["port"]
    status = at(done_ns)
    assert status["position_s"] == pytest.approx((done_ns - timeline.start_ns) / 1e9, abs=1e-6)
    [command] = client.get("/api/commands").json()
    assert command["status"] == "done" and command["exit"] == "completed"
    assert client.get(f"/api/commands/{command['id']}").json()["peak_force"] == command["peak_force"]
    assert client.get("/api/geometry").json()["scene"] == "quick_connect"
    [frame] = client.get("/api/frames").json()  # the scene's own, as recorded at the trial's start
    assert frame["name"] == "mouth_axis" and frame["source"] == "scene"
    assert frame["pose"] == timeline.frames_at(done_ns)[0]["pose"]
    assert client.get("/api/task").json()["success"] is True
    assert client.get("/api/health").json()["sim_time"] == client.get("/api/state").json()["sim_time"]


def test_nothing_can_be_sent_and_bad_controls_are_named(timeline: Timeline) -> None:
    client, player = _client(timeline)
    before = player.now()
    for path, body in (
        ("/api/commands", {"type": "rwe", "axes": ["z"], "duration": 1.0}),
        ("/api/stop", None),
        ("/api/scene", {"name": "lid"}),
        ("/api/frames", {"name": "mine", "pose": "tool"}),
    ):
        response = client.post(path, json=body)
        assert response.status_code == 409 and "replay" in response.json()["detail"]
    for body, field in (
        ({"speed": 100.0}, "speed"),
        ({"position_s": 1e6}, "position_s"),
        ({"playing": "yes"}, "playing"),
        ({"rewind": True}, "rewind"),
    ):
        response = client.put("/_replay", json=body)
        assert response.status_code == 422 and field in response.json()["detail"], body
    assert player.now() == before  # refused changes change nothing


def past_keepalives(ws: Any, paused_seq: int) -> dict[str, Any]:
    """The next message that is not the paused state again: paused, the socket re-sends it every
    KEEPALIVE_S, and a loaded machine can let one go out between a read and the test's next
    move (a hogged CI run read it where a seek's frames were expected)."""
    message: dict[str, Any] = json.loads(ws.receive_text())
    while message.get("type") == "state" and message["seq"] == paused_seq:
        message = json.loads(ws.receive_text())
    return message


def test_the_socket_replays_messages_in_recorded_order_at_speed(
    timeline: Timeline, monkeypatch: pytest.MonkeyPatch
) -> None:
    clock = FakeClock()  # the playhead's: the socket sends what it passed, whatever the machine's load
    # Keep-alives 2 s apart here (0.25 s in use): a seek that waited for the next one would come
    # a second or more after it, far from what a loaded machine adds (0.14 s in a hogged CI run,
    # which a bound of half of 0.25 s failed).
    monkeypatch.setattr(replay_app, "KEEPALIVE_S", 2.0)
    client, player = _client(timeline, clock)
    player.set(position_ns=timeline.start_ns, speed=16.0)
    received: list[dict[str, Any]] = []
    with client.websocket_connect("ws://127.0.0.1:8123/api/telemetry") as ws:
        # At once: the task frames at the playhead (a console lists them), then the state there.
        frames = json.loads(ws.receive_text())
        assert frames["type"] == "frames" and frames["frames"] == timeline.frames_at(timeline.start_ns) != []
        received.append(json.loads(ws.receive_text()))
        # Paused, a seek sends the frames and the state there at once (not at the next keep-alive).
        middle = timeline.telemetry.values[len(timeline.telemetry.values) // 2]
        middle_ns = timeline.telemetry.times_ns[len(timeline.telemetry.values) // 2]
        sought = time.monotonic()
        player.set(position_ns=middle_ns)
        assert past_keepalives(ws, received[0]["seq"])["type"] == "frames"
        assert json.loads(ws.receive_text())["seq"] == middle["seq"]
        assert time.monotonic() - sought < 1.0
        player.set(position_ns=timeline.start_ns)
        assert past_keepalives(ws, middle["seq"])["type"] == "frames"
        assert json.loads(ws.receive_text())["seq"] == received[0]["seq"]
        player.set(playing=True)
        clock.now += 0.125  # at 16x: two seconds of the recording pass
        played_to_ns = player.now().position_ns
        assert played_to_ns == timeline.start_ns + 2_000_000_000
        expected = [json.loads(o.text) for o in timeline.between(timeline.start_ns, played_to_ns)]
        received.append(past_keepalives(ws, received[0]["seq"]))
        while len(received) < 1 + len(expected):
            received.append(json.loads(ws.receive_text()))
        # The playhead stands (its clock does): next comes the state there again, nothing later.
        kept_alive = json.loads(ws.receive_text())
    played = [{k: v for k, v in m.items() if k != "sent_at"} for m in received[1:]]
    assert played == expected  # every message the playhead passed, in recorded order
    states = [m for m in played if m["type"] == "state"]
    assert len(states) >= 1.9 * 50  # the recording's 50 Hz telemetry
    assert [s["seq"] for s in states] == list(range(states[0]["seq"], states[0]["seq"] + len(states)))
    assert {k: v for k, v in kept_alive.items() if k != "sent_at"} == timeline.state_at(played_to_ns)
    assert all(abs(m["sent_at"] - time.time()) < 5.0 for m in received)


def test_the_console_replays_a_recording_with_play_pause_and_seek(
    recording_path: Path, timeline: Timeline, browser: object
) -> None:
    from tests.console_page import _load

    port = free_port()
    with running(
        "replay", str(recording_path), "--port", str(port), "--paused", health="/", startup_timeout=90.0
    ) as replay:
        assert replay.url == f"http://127.0.0.1:{port}"  # the console, not its robot stand-in
        page = _load(browser, replay.url, (1100, 900))
        until(page, "document.querySelector('#ptwl-replay')?.dataset.playing === '0'")
        until(page, "document.querySelector('#ptwl-telemetry')?.dataset.seq > 0")
        # Watched, not commanded: no form, no control to take, no STOP.
        for button in ("Send cmd", "Take control", "STOP"):
            assert page.get_by_role("button", name=button).count() == 0, button
        first = timeline.telemetry.values[0]
        assert port_mm(page) == pytest.approx([1000 * v for v in first["port"]["position"]], abs=0.11)
        # At the start the onboard operator's state machine has already started: at 0 link delay
        # it reached the robot and started in the first tick, and its events are logged then.
        until(page, "document.querySelector('#ptwl-command')?.dataset.status === 'running'")
        assert "STATE_MACHINE #1: running by onboard operator" in page.locator("#ptwl-command").inner_text()
        # Seek to the end: the history is the recording's, with the machine's exit.
        slider = page.get_by_role("slider")
        slider.focus()
        slider.press("End")
        until(page, "document.querySelector('#ptwl-command')?.dataset.status === 'completed'")
        last = timeline.telemetry.values[-1]
        until(page, f"document.querySelector('#ptwl-telemetry')?.dataset.seq == {last['seq']}")
        assert port_mm(page) == pytest.approx([1000 * v for v in last["port"]["position"]], abs=0.11)
        # Back to the start and play: the playhead moves, the command appears when it was sent.
        slider.press("Home")
        until(page, "document.querySelector('#ptwl-command')?.dataset.status !== 'completed'")
        page.get_by_role("button", name="Play").click()
        until(page, "document.querySelector('#ptwl-replay')?.dataset.playing === '1'")
        until(page, "Number(document.querySelector('#ptwl-replay')?.dataset.position) > 0.5")
        until(
            page,
            "['running', 'completed'].includes(document.querySelector('#ptwl-command')?.dataset.status)",
        )
        page.get_by_role("button", name="Pause").click()
        until(page, "document.querySelector('#ptwl-replay')?.dataset.playing === '0'")
        paused_at = float(page.locator("#ptwl-replay").get_attribute("data-position") or "nan")
        time.sleep(0.6)
        status = httpx.get(f"{robot_url(replay.output)}/_replay", timeout=5.0).json()
        assert not status["playing"] and status["position_s"] == pytest.approx(paused_at, abs=0.3)
        page.close()


def robot_url(output: list[str]) -> str:
    """The replay's robot stand-in, as `ptwl replay` announced it (once its console is up: the
    line may come just after the console first answers)."""
    deadline = time.monotonic() + 10.0
    while not (lines := [line for line in output if "replaying" in line]) and time.monotonic() < deadline:
        time.sleep(0.05)
    return lines[0].split(" robot ")[1].split()[0]


def test_the_stand_in_checks_host_and_origin_and_stays_on_loopback(
    timeline: Timeline, recording_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from starlette.testclient import WebSocketDenialResponse

    from ptwl.cli import main

    client, _ = _client(timeline)
    assert client.get("/_replay").status_code == 200
    assert client.get("/_replay", headers={"host": "evil.example:8123"}).status_code == 400  # rebinding
    with (
        pytest.raises(WebSocketDenialResponse) as denied,
        client.websocket_connect(
            "ws://127.0.0.1:8123/api/telemetry", headers={"origin": "http://evil.example"}
        ),
    ):
        pass
    assert denied.value.status_code == 403
    response = client.put("/_replay", json={"playing": True}, headers={"origin": "http://evil.example"})
    assert response.status_code == 403  # a foreign page cannot drive the playhead either
    assert main(["replay-serve", str(recording_path), "--host", "0.0.0.0"]) == 2
    assert "needs an access token" in capsys.readouterr().err
