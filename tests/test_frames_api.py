"""Task frames through the API: list, add from the tool or a typed pose, use, delete; what may
not be done says why (409, 422) and loses nothing; every telemetry client hears of a change."""

import json
import math

import httpx
import numpy as np
import pytest
from websockets.sync.client import connect

from ptwl.launcher import ServiceProcess
from robot_sim.params import PtwlParams
from robot_sim.task_frames import TaskFrame, TaskFrames
from server.client import RobotClient
from server.commands import CommandBook

QUARTER_TURN_ABOUT_X = [math.cos(math.pi / 4), math.sin(math.pi / 4), 0.0, 0.0]  # z -> base -y


def test_a_frame_from_the_tool_pose_and_a_move_in_it(robot: RobotClient) -> None:
    port = robot.state().port
    frame = robot.add_frame("here")
    assert frame.source == "operator" and frame.defined_by.startswith("tool pose at sim time")
    np.testing.assert_allclose(frame.pose.position, port.position, atol=1e-4)  # the robot holds still
    assert abs(float(np.dot(frame.pose.quaternion, port.quaternion))) == pytest.approx(1.0, abs=1e-6)
    assert [f.name for f in robot.frames()] == ["here"]  # free_space has no fixture frames


def test_a_typed_frame_is_normalized_and_moves_go_along_its_axes(robot: RobotClient) -> None:
    doubled = [2.0 * v for v in QUARTER_TURN_ABOUT_X]
    frame = robot.add_frame("side", {"position": [0.4, 0.0, 0.3], "quaternion": doubled})
    np.testing.assert_allclose(frame.pose.quaternion, QUARTER_TURN_ABOUT_X, atol=1e-12)
    before = np.asarray(robot.state().port.position)
    done = robot.run(
        "ptwl",
        translation=[0.0, 0.0, 0.02],
        frame="side",
        duration=1.0,
        position_tolerance=0.0005,
        timeout=10.0,
    )
    assert done.exit == "goal_reached"
    moved = np.asarray(robot.state().port.position) - before
    np.testing.assert_allclose(moved, [0.0, -0.02, 0.0], atol=0.0006)  # the frame's z is base -y


def test_what_cannot_be_done_to_frames_says_why(robot: RobotClient, server: ServiceProcess) -> None:
    robot.add_frame("kept", {"position": [0.4, 0.0, 0.3], "quaternion": [1.0, 0.0, 0.0, 0.0]})
    with httpx.Client(base_url=server.url) as http:
        cases = [
            ({"name": "kept", "pose": "tool"}, 409, "exists"),
            ({"name": "tool", "pose": "tool"}, 409, "built-in"),
            ({"name": "9lives", "pose": "tool"}, 422, "name: String should match pattern"),
            (
                {"name": "far", "pose": {"position": [3.0, 0.0, 0.0], "quaternion": [1, 0, 0, 0]}},
                422,
                "within 2 m",
            ),
            (
                {"name": "zero", "pose": {"position": [0.3, 0.0, 0.3], "quaternion": [0, 0, 0, 0]}},
                422,
                "non-zero",
            ),
            ({"name": "x", "pose": "tool", "colour": "red"}, 422, "colour: Extra inputs are not permitted"),
            ({"name": "x", "pose": "elbow"}, 422, "pose"),
        ]
        for body, code, said in cases:
            response = http.post("/api/frames", json=body)
            assert response.status_code == code, body
            assert said in response.json()["detail"], response.json()
        assert http.delete("/api/frames/nope").status_code == 404
    assert [f.name for f in robot.frames()] == ["kept"]  # nothing lost, nothing half-made


def test_a_frame_named_by_a_queued_command_stays(robot: RobotClient, server: ServiceProcess) -> None:
    robot.add_frame("busy", {"position": [0.4, 0.0, 0.3], "quaternion": [1.0, 0.0, 0.0, 0.0]})
    running = robot.command("ptwl", translation=[0.0, 0.0, 0.01], frame="base", duration=3.0)
    queued = robot.command("ptwl", translation=[0.0, 0.0, -0.01], frame="busy", duration=1.0)
    with httpx.Client(base_url=server.url) as http:
        response = http.delete("/api/frames/busy")
    assert response.status_code == 409 and f"[{queued.id}]" in response.json()["detail"]
    robot.stop()  # drops the queued one
    assert robot.get(running.id).exit == "aborted"
    assert robot.delete_frame("busy").name == "busy"
    assert robot.frames() == []


def test_scene_frames_and_a_reset_drops_the_operators(robot: RobotClient) -> None:
    robot.reset_scene("sleeve_on_peg", 5)
    robot.add_frame("mine")
    names = [(f.name, f.source) for f in robot.frames()]
    assert names == [("peg_axis", "scene"), ("mine", "operator")]
    geometry = robot.geometry()
    peg_top = robot.frames()[0].pose.position
    assert peg_top[2] == pytest.approx(0.26, abs=1e-9)  # the peg's tip, where the seed put it
    assert geometry.scene == "sleeve_on_peg"
    robot.reset_scene("sleeve_on_peg", 5)
    assert [f.name for f in robot.frames()] == ["peg_axis"]


def test_telemetry_announces_frames(robot: RobotClient) -> None:
    """First the whole list, then each change alone (tests/test_frames_cap.py: sizes, deltas)."""
    with connect(robot.telemetry_url(), open_timeout=5.0) as ws:
        first = json.loads(ws.recv(timeout=5.0))
        robot.add_frame("heard")
        for _ in range(200):
            message = json.loads(ws.recv(timeout=5.0))
            if message["type"] == "frames":
                break
        else:
            pytest.fail("no frames message")
    assert first["type"] == "frames" and first["frames"] == []
    assert [f["name"] for f in message["added"]] == ["heard"] and message["removed"] == []
    assert message["rev"] == first["rev"] + 1


def test_a_command_whose_frame_is_gone_at_its_turn_ends_aborted_and_the_next_runs() -> None:
    """The start gate (for a frame lost between the check and the start, e.g. in a reset): the
    command ends `aborted` unstarted, saying why, and the queue goes on."""
    frames = TaskFrames([TaskFrame("brief", (0.4, 0.0, 0.3), (1.0, 0.0, 0.0, 0.0), "operator", "typed pose")])
    book = CommandBook(queue_max=8, history_max=100)
    gone = book.submit(PtwlParams(frame="brief"))
    fine = book.submit(PtwlParams(frame="base"))
    frames.remove("brief", [])
    with book.held() as held:
        started = held.start_next(lambda record: None, 0.0, frames.missing_reason)
    assert started is not None and started.id == fine.id
    record = book.get(gone.id)
    assert record is not None and record.exit == "aborted" and record.started_at is None
    assert "its task frame is gone (frame 'brief')" in record.detail
