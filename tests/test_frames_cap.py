"""Task frames are capped per scene, and the telemetry carries their changes, not the whole list.

The defect (issue 26): no cap, and each add re-sent every frame: at ~2,000 frames an add was a
286 KB telemetry message, POST p50 43 ms and the state telemetry through the link fell to 33.6 Hz.
Now a scene holds at most MAX_OPERATOR_FRAMES operators' frames (409 past it, naming the number);
a client gets the whole list first, then each add or delete alone (`added`/`removed`), numbered by
`rev`, and a lost change is noticed (a gap in `rev`, or a state's `frames_rev`) and mended from
GET /api/frames."""

import json
import threading
import time
from collections.abc import Iterator
from typing import Any

import httpx
import pytest
from websockets.sync.client import connect

from robot_sim.behaviors.base import Pose
from robot_sim.task_frames import MAX_OPERATOR_FRAMES, FrameLimitError, TaskFrame, TaskFrames
from robot_sim.telemetry import FramesMirror
from server.client import RobotClient
from server.commands import CommandBook
from server.models import FrameModel
from server.runner import SimRunner
from web.feed import TelemetryFeed

TYPED = {"position": [0.4, 0.1, 0.3], "quaternion": [1.0, 0.0, 0.0, 0.0]}


def _operator(name: str) -> TaskFrame:
    return TaskFrame(name, (0.4, 0.0, 0.3), (1.0, 0.0, 0.0, 0.0), "operator", "typed pose")


def _runner(scene: str = "free_space") -> tuple[SimRunner, list[dict[str, Any]]]:
    """A runner whose thread never starts: its published messages, decoded, in order."""
    published: list[dict[str, Any]] = []
    book = CommandBook(8, 8, lambda record: None)
    runner = SimRunner(scene, 0, 50.0, book, lambda text: published.append(json.loads(text)))
    return runner, published


# ------------------------------------------------------------------------------------ the cap
def test_the_cap_counts_operator_frames_only_and_a_delete_makes_room() -> None:
    scene_own = TaskFrame("plate_normal", (0.5, 0.0, 0.1), (1.0, 0.0, 0.0, 0.0), "scene", "site plate")
    frames = TaskFrames([scene_own])
    for i in range(MAX_OPERATOR_FRAMES):
        frames.add(_operator(f"f{i}"))
    assert MAX_OPERATOR_FRAMES == 64 and frames.operator_count() == 64 and len(frames.all()) == 65
    with pytest.raises(FrameLimitError, match="at most 64 per scene"):
        frames.add(_operator("one_more"))
    assert "one_more" not in frames.names()
    frames.remove("f3", users=[])
    frames.add(_operator("one_more"))
    assert frames.operator_count() == 64


def test_the_65th_frame_is_refused_with_the_limit_named(robot: RobotClient) -> None:
    robot.reset_scene("surface")  # it has a frame of its own (plate_normal): that one does not count
    scene_own = [f.name for f in robot.frames()]
    assert scene_own == ["plate_normal"]
    with httpx.Client(base_url=robot.base_url, timeout=10.0) as http:
        for i in range(MAX_OPERATOR_FRAMES):
            assert http.post("/api/frames", json={"name": f"f{i}", "pose": TYPED}).status_code == 201
        refused = http.post("/api/frames", json={"name": "f64", "pose": TYPED})
        assert refused.status_code == 409
        assert "at most 64 per scene" in refused.json()["detail"] and "'f64'" in refused.json()["detail"]
        assert len(robot.frames()) == 1 + 64  # nothing half-added
        assert http.delete("/api/frames/f10").status_code == 200
        assert http.post("/api/frames", json={"name": "f64", "pose": TYPED}).status_code == 201
    robot.reset_scene("surface")  # a reset drops the operators': room for 64 again
    assert robot.add_frame("again", TYPED).name == "again"


# ------------------------------------------------------------------ what an add or delete sends
def test_an_add_costs_the_same_bytes_with_1_or_60_frames() -> None:
    runner, published = _runner()
    sizes: dict[int, int] = {}
    for i in range(61):
        before = len(published)
        runner.add_frame(f"frame_{i:02d}", Pose((0.4, 0.1, 0.3), (1.0, 0.0, 0.0, 0.0)))
        [message] = published[before:]  # one message an add
        count = len(runner.frames_listed()[0])
        if count in (1, 60):
            sizes[count] = len(json.dumps(message).encode())  # bytes on the wire
        assert message["added"][0]["name"] == f"frame_{i:02d}" and message["removed"] == []
        assert "frames" not in message
    # Byte for byte but the rev's digits (1 then 60); the whole list at 60 is ~45 times it.
    assert sizes[60] - sizes[1] == len("60") - len("1")
    assert sizes[60] < 400 and len(runner.frames_text) > 40 * sizes[1]
    before = len(published)
    runner.remove_frame("frame_30")
    [removal] = published[before:]
    assert removal["added"] == [] and removal["removed"] == ["frame_30"] and len(json.dumps(removal)) < 100
    # The whole list (a new client's first message) is what the frames are, at the latest rev.
    whole = json.loads(runner.frames_text)
    assert len(whole["frames"]) == 60 and whole["rev"] == removal["rev"]
    assert runner.latest_state["frames_rev"] <= removal["rev"]  # states say which rev came last
    assert runner._state()["frames_rev"] == removal["rev"]


def test_a_scene_load_sends_the_whole_list_again() -> None:
    runner, published = _runner("surface")
    runner.add_frame("mine", None)
    runner.reset_scene("surface", 0)
    whole = published[-1]
    assert [f["name"] for f in whole["frames"]] == ["plate_normal"]  # the operator's dropped
    assert whole["rev"] == published[-2]["rev"] + 1


# ------------------------------------------------------------ a client that applies the changes
def test_a_client_applying_the_changes_ends_with_get_api_frames(robot: RobotClient) -> None:
    robot.reset_scene("surface")
    robot.add_frame("before_connect", TYPED)
    mirror = FramesMirror()
    with connect(robot.telemetry_url(), open_timeout=5.0) as ws:
        first = json.loads(ws.recv(timeout=5.0))
        assert first["type"] == "frames"  # the whole list first, before any state
        assert first["frames"] == [f.model_dump() for f in robot.frames()]
        assert mirror.apply(first) == "changed"
        for name in ("a", "b", "c", "d"):
            robot.add_frame(name, TYPED if name != "c" else "tool")
        robot.delete_frame("b")
        robot.delete_frame("before_connect")
        robot.add_frame("b", {"position": [0.3, -0.1, 0.25], "quaternion": [0.0, 1.0, 0.0, 0.0]})
        changes = 7
        state_rev = None
        while state_rev != first["rev"] + changes:  # a state after the last change
            message = json.loads(ws.recv(timeout=5.0))
            if message["type"] == "frames":
                assert "frames" not in message  # a change, not the list
                assert mirror.apply(message) == "changed"
            elif message["type"] == "state":
                state_rev = message["frames_rev"]
                assert state_rev == mirror.rev  # nothing lost on a direct socket
    listed, listed_rev = robot.frames_at_rev()
    assert mirror.frames() == [f.model_dump() for f in listed]
    assert [f["name"] for f in mirror.frames()] == ["plate_normal", "a", "c", "d", "b"]
    assert listed_rev == mirror.rev  # GET /api/frames says which message its list matches


def test_the_mirror_skips_what_it_has_and_says_when_one_was_lost() -> None:
    runner, published = _runner()
    mirror = FramesMirror()
    assert mirror.apply({"type": "frames", "rev": 1, "added": [], "removed": []}) == "gap"  # no list yet
    mirror.apply(json.loads(runner.frames_text))
    for name in ("a", "b", "c"):
        runner.add_frame(name, None)
    a, b, c = published[-3:]
    assert mirror.apply(a) == "changed"
    assert mirror.apply(a) == "stale"  # already in it (a list taken after it was sent)
    assert mirror.apply(c) == "gap" and [f["name"] for f in mirror.frames()] == ["a"]  # b lost
    assert mirror.apply(b) == "changed" and mirror.apply(c) == "changed"
    assert [f["name"] for f in mirror.frames()] == ["a", "b", "c"] and mirror.rev == c["rev"]


class _ScriptedRobot:
    """A RobotClient stand-in: its telemetry is a script; GET /api/frames answers the runner's."""

    def __init__(self, runner: SimRunner, script: list[dict[str, Any]]) -> None:
        self._runner, self._script = runner, script
        self.frames_asked = 0

    def telemetry(self, open_timeout: float, idle_s: float, close_timeout: float) -> Iterator[dict[str, Any]]:
        yield from self._script
        while True:
            time.sleep(0.02)  # only so the feed does not spin while the test waits
            yield {"type": "idle"}

    def frames_at_rev(self) -> tuple[list[FrameModel], int | None]:
        self.frames_asked += 1
        whole = json.loads(self._runner.frames_text)
        return [FrameModel.model_validate(f) for f in whole["frames"]], whole["rev"]


@pytest.mark.parametrize("lost", ["a_middle_change", "the_last_change"])
def test_the_console_mends_a_change_the_link_lost(lost: str) -> None:
    """The link may drop WebSocket messages. A middle change lost shows as a gap at the next; the
    last one, with no change after it, by the next state's `frames_rev`: either way the console's
    list ends as the robot's."""
    runner, published = _runner()
    script = [json.loads(runner.frames_text)]
    for name in ("a", "b", "c"):
        runner.add_frame(name, None)
    runner.remove_frame("a")
    changes = published[-4:]
    drop = 1 if lost == "a_middle_change" else 3
    script += [m for i, m in enumerate(changes) if i != drop]
    script.append({"type": "state", "frames_rev": runner._state()["frames_rev"]})
    robot = _ScriptedRobot(runner, script)
    heard: list[list[dict[str, Any]]] = []
    mended = threading.Event()
    want = json.loads(runner.frames_text)["frames"]

    def on_frames(frames: list[dict[str, Any]]) -> None:
        heard.append(frames)
        if frames == want:
            mended.set()

    feed = TelemetryFeed(robot, lambda s, t: None, lambda c: None, lambda link: None, on_frames)  # type: ignore[arg-type]
    feed.start()
    try:
        assert mended.wait(10.0), heard
    finally:
        feed.close()
    assert robot.frames_asked == 1 and feed.frames_refetches == 1
    assert [f["name"] for f in heard[-1]] == ["b", "c"]


def test_nothing_lost_means_no_refetch() -> None:
    runner, published = _runner()
    script = [json.loads(runner.frames_text)]
    runner.add_frame("a", None)
    runner.add_frame("b", None)
    script += published[-2:]
    state = {"type": "state", "frames_rev": runner._state()["frames_rev"]}
    script += [state, state]  # the first state's rev is judged before the second is handled
    robot = _ScriptedRobot(runner, script)
    heard: list[list[dict[str, Any]]] = []
    states = 0
    second_state = threading.Event()

    def on_state(state: dict[str, Any], arrived: float) -> None:
        nonlocal states
        states += 1
        if states == 2:
            second_state.set()

    feed = TelemetryFeed(robot, on_state, lambda c: None, lambda link: None, heard.append)  # type: ignore[arg-type]
    feed.start()
    try:
        assert second_state.wait(10.0)
    finally:
        feed.close()
    assert [[f["name"] for f in frames] for frames in heard] == [[], ["a"], ["a", "b"]]
    assert feed.frames_refetches == 0 and robot.frames_asked == 0
