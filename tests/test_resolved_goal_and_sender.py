"""What the robot tells a console so it can show the truth under delay (issue 10, points 2, 4, 6):
the absolute goal it resolved when a command started, who sent each command, and the task's
progress in every telemetry state."""

import json

import httpx
import numpy as np
import pytest
import websockets.sync.client

from ptwl.launcher import ServiceProcess
from server.client import RobotClient
from server.models import SENDER_HEADER


def test_a_queued_relative_ptwl_resolves_against_the_port_where_it_really_starts(robot: RobotClient) -> None:
    """Two PTWLs sent back to back (+60 mm y, then -40 mm y, base frame): the second's goal is
    the port *after the first* -40 mm, not the port at send time -40 mm (which a console that
    guessed would draw 60 mm off)."""
    p0 = np.array(robot.state().port.position)
    ptwl = {"rotation": [0.0, 0.0, 0.0], "frame": "base", "duration": 1.0, "watchdog": 5.0}
    first = robot.ptwl(translation=[0.0, 0.06, 0.0], **ptwl)
    second = robot.ptwl(translation=[0.0, -0.04, 0.0], **ptwl)
    queued = robot.get(second.id)
    assert queued.goal is None  # not resolved until it starts
    done_first = robot.wait(first.id, timeout=15)
    done_second = robot.wait(second.id, timeout=15)
    assert done_first.exit == "goal_reached" and done_second.exit == "goal_reached"
    assert done_first.goal is not None and done_second.goal is not None
    first_goal = np.array(done_first.goal.position)
    assert first_goal == pytest.approx(p0 + [0.0, 0.06, 0.0], abs=1e-4)
    # The second resolved against where the first left the port (within the first's tolerance).
    assert done_first.final_port is not None
    port_at_second_start = np.array(done_first.final_port.position)
    second_goal = np.array(done_second.goal.position)
    assert second_goal == pytest.approx(port_at_second_start + [0.0, -0.04, 0.0], abs=1e-3)
    assert second_goal[1] - p0[1] == pytest.approx(0.02, abs=3e-3)  # not -0.04: it was relative
    assert np.array(done_second.final_port.position) == pytest.approx(second_goal, abs=3e-3)  # type: ignore[union-attr]


def test_the_running_event_carries_the_goal(server: ServiceProcess, robot: RobotClient) -> None:
    with websockets.sync.client.connect(server.url.replace("http", "ws") + "/api/telemetry") as ws:
        accepted = robot.ptwl(translation=[0.0, 0.0, -0.01], duration=0.5, watchdog=5.0)
        goal = None
        for _ in range(2000):
            message = json.loads(ws.recv(timeout=5))
            if (
                message["type"] == "command"
                and message["id"] == accepted.id
                and message["status"] == "running"
            ):
                goal = message["goal"]
                break
    assert goal is not None and len(goal["position"]) == 3 and len(goal["quaternion"]) == 4
    assert robot.wait(accepted.id, timeout=10).goal.position == pytest.approx(goal["position"])  # type: ignore[union-attr]


def test_each_command_records_who_sent_it(robot: RobotClient) -> None:
    named = robot.command("rwe", sender="console 127.0.0.1:8080 operator 2", duration=0.05)
    anonymous = robot.rwe(duration=0.05)
    assert robot.wait(named.id, timeout=10).sender == "console 127.0.0.1:8080 operator 2"
    assert robot.wait(anonymous.id, timeout=10).sender is None
    listed = {c.id: c.sender for c in robot.commands()}
    assert listed[named.id] == "console 127.0.0.1:8080 operator 2"


@pytest.mark.parametrize(
    "bad",
    [
        "",
        "x" * 65,
        "tab\there",
        "caf\u00e9",
        "<img src=x onerror=import('//127.0.0.1:18090/p.js')>",
        'a"b',
        "a&b",
        "<b>bold</b>",  # markup with no quote or ampersand
        "a=1;b",
    ],
)
def test_a_bad_sender_is_refused_naming_the_header(
    server: ServiceProcess, robot: RobotClient, bad: str
) -> None:
    before = len(robot.commands(limit=1000))
    response = httpx.post(
        server.url + "/api/commands",
        json={"type": "rwe", "duration": 0.05},
        headers={SENDER_HEADER: bad.encode("utf-8")},  # type: ignore[dict-item]
    )
    assert response.status_code == 422, response.text
    assert SENDER_HEADER in json.dumps(response.json()["detail"])
    assert len(robot.commands(limit=1000)) == before  # nothing queued


def test_telemetry_states_carry_the_task_progress(server: ServiceProcess, robot: RobotClient) -> None:
    robot.reset_scene("surface")
    try:
        state = robot.state()
        task = robot.task()
        assert state.task is not None
        assert state.task.predicate == task.predicate and state.task.unit == task.unit
        assert state.task.target == task.target and state.task.success is False
    finally:
        robot.reset_scene("free_space")
