"""Bad input gets a clear 4xx naming the field and the allowed range, and loses nothing.

Every case runs with one command running and one queued; afterwards the simulation is still
advancing, both commands are untouched, and a valid command still runs to its exit.
"""

import time
from collections.abc import Callable, Iterator

import httpx
import pytest

from ptwl.launcher import ServiceProcess
from robot_sim.scenes import SCENES
from server.client import RobotClient

BAD_COMMANDS = {
    "json_nan_token": ('{"type": "ptwl", "duration": NaN}', 422, ["duration", "finite", "(0, 600] s"]),
    "json_infinity_token": (
        '{"type": "ptwl", "translation": [0, Infinity, 0]}',
        422,
        ["translation", "component 1 must be a finite number"],
    ),
    "translation_over_1_m": (
        '{"type": "ptwl", "translation": [0.8, 0.8, 0]}',
        422,
        ["translation", "<= 1 m"],
    ),
    "unknown_task_frame": (
        '{"type": "ptwl", "frame": "peg_axis"}',
        422,
        ["frame: unknown task frame 'peg_axis'; valid: tool, base"],
    ),
    "unknown_gains_frame": (
        '{"type": "rwe", "frame": "base", "gains_frame": "x"}',
        422,
        ["gains_frame", "Extra inputs are not permitted"],
    ),
    "unknown_dither_frame": (
        '{"type": "dither", "frame": "nowhere"}',
        422,
        ["frame: unknown task frame 'nowhere'"],
    ),
    "frame_name_not_a_name": ('{"type": "ptwl", "frame": "../tool"}', 422, ["frame", "should match pattern"]),
    "rotation_over_pi": ('{"type": "ptwl", "rotation": [0, 0, 3.5]}', 422, ["rotation", "<= 3.14159 rad"]),
    "duration_zero": ('{"type": "ptwl", "duration": 0}', 422, ["duration", "(0, 600] s"]),
    "duration_negative": ('{"type": "rwe", "duration": -2}', 422, ["duration", "(0, 600] s"]),
    "duration_over_600": ('{"type": "dither", "duration": 601}', 422, ["duration", "(0, 600] s"]),
    "watchdog_shorter_than_duration": (
        '{"type": "ptwl", "duration": 5, "watchdog": 2}',
        422,
        ["watchdog (2 s) must be >= duration (5 s)"],
    ),
    "dither_progress_past_its_travel": (
        '{"type": "dither", "travel": 0.01, "progress": 0.02}',
        422,
        ["progress (0.02 m) must be <= travel (0.01 m)"],
    ),
    "dither_progress_within_its_tolerance": (
        '{"type": "dither", "progress": 0.001}',
        422,
        ["progress", "[0.002, 1] m"],
    ),
    "force_threshold_zero": (
        '{"type": "ptwl", "force_threshold": 0}',
        422,
        ["force_threshold", "(0, 500] N"],
    ),
    "torque_threshold_negative": (
        '{"type": "dither", "torque_threshold": -1}',
        422,
        ["torque_threshold", "(0, 50] N m"],
    ),
    # Issue 9: what used to get through.
    "force_threshold_1e308": (
        '{"type": "ptwl", "force_threshold": 1e308}',
        422,
        ["force_threshold", "(0, 500] N", "got 1e+308"],
    ),
    # Issue 14: commands that expire.
    "max_age_without_sent_at": ('{"type": "ptwl", "max_age": 5}', 422, ["max_age needs sent_at"]),
    "max_age_zero": ('{"type": "rwe", "sent_at": 1, "max_age": 0}', 422, ["max_age", "(0, 86400] s"]),
    "valid_until_sim_time_negative": (
        '{"type": "dither", "valid_until_sim_time": -1}',
        422,
        ["valid_until_sim_time", "[0, 1e+09] s"],
    ),
    "monitor_forgetting_below_half": (
        '{"type": "ptwl", "monitor": {"forgetting": [0.2, 0.99]}}',
        422,
        ["monitor.forgetting[0]", "[0.5, 1]"],
    ),
    "monitor_unknown_setting": (
        '{"type": "dither", "monitor": {"gain": 1}}',
        422,
        ["monitor.gain", "Extra inputs"],
    ),
    "monitor_on_rwe": ('{"type": "rwe", "monitor": {}}', 422, ["monitor", "Extra inputs"]),
    "duration_true_is_not_1_s": ('{"type": "ptwl", "duration": true}', 422, ["duration", "valid number"]),
    "duration_string_is_not_a_number": (
        '{"type": "rwe", "duration": "5"}',
        422,
        ["duration", "valid number"],
    ),
    "duplicate_key": (
        '{"type": "ptwl", "force_threshold": 20, "force_threshold": 400}',
        422,
        ["duplicate key 'force_threshold'"],
    ),
    "nesting_20k_deep": (
        '{"type": "ptwl", "x": ' + "[" * 20_000 + "]" * 20_000 + "}",
        422,
        ["nested deeper"],
    ),
    "on_breach_unknown": ('{"type": "ptwl", "on_breach": "stop"}', 422, ["on_breach", "'limit' or 'freeze'"]),
    "dither_on_breach_unknown": (
        '{"type": "dither", "on_breach": 1}',
        422,
        ["on_breach", "'limit' or 'freeze'"],
    ),
    "gains_frame_unknown": (
        '{"type": "ptwl", "gains_frame": "world"}',
        422,
        ["gains_frame: unknown task frame 'world'; valid: tool, base"],
    ),
    "rwe_frame_unknown": (
        '{"type": "rwe", "frame": "port"}',
        422,
        ["frame: unknown task frame 'port'; valid: tool, base"],
    ),
    "conical_dither_is_gone": (
        '{"type": "dither", "mode": "conical"}',
        422,
        ["mode", "'torsional' or 'translational'"],
    ),
    "damping_under_the_floor": (
        '{"type": "ptwl", "stiffness": [500,500,500,10,10,10], "damping": [150,1000,1000,50,50,50]}',
        422,
        ["damping[0] (x) must be in [200, 50000] N s/m"],
    ),
    "time_constant_under_first_order_floor": (
        '{"type": "ptwl", "stiffness": [4000,100,100,10,10,10], "damping": [1000,1000,1000,50,50,50]}',
        422,
        ["damping[0]/stiffness[0] (x) must be >= 0.3 s", "first-order"],
    ),
    "damping_zero": (
        '{"type": "ptwl", "stiffness": [100,100,100,10,10,10], "damping": [1000,0,1000,50,50,50]}',
        422,
        ["damping[1] (y) must be > 0 N s/m"],
    ),
    "stiffness_negative": (
        '{"type": "ptwl", "stiffness": [100,100,-5,10,10,10], "damping": [1000,1000,1000,50,50,50]}',
        422,
        ["stiffness[2] (z) must be in [0, 20000] N/m"],
    ),
    "unstable_gains": (
        '{"type": "ptwl", "stiffness": [100,100,100,10,10,10], "damping": [150,1000,1000,50,50,50]}',
        422,
        ["damping[0] (x) must be in [200, 50000] N s/m", "stable"],
    ),
    "unknown_stiffness_preset": (
        '{"type": "ptwl", "preset": "bouncy"}',
        422,
        ["unknown stiffness preset 'bouncy'", "hinge, medium, planar, soft, stiff"],
    ),
    "unknown_dither_preset": (
        '{"type": "dither", "preset": "shake"}',
        422,
        ["unknown dither preset 'shake'"],
    ),
    "wrong_type": ('{"type": "jump"}', 422, ["'ptwl', 'rwe', 'dither'", "type"]),
    "missing_type": ('{"duration": 1}', 422, ["type"]),
    "malformed_json": ('{"type": "ptwl", "duration": ', 422, ["malformed JSON"]),
    "unknown_field": ('{"type": "ptwl", "translaton": [0, 0, 0.01]}', 422, ["translaton", "Extra inputs"]),
    "body_over_64_kib": ('{"type": "ptwl", "pad": "' + "x" * 70_000 + '"}', 413, ["65536 byte limit"]),
}


@pytest.fixture
def busy(robot: RobotClient) -> Iterator[tuple[RobotClient, int, int]]:
    """One long command running and one queued behind it."""
    running = robot.ptwl(translation=[0.0, 0.0, -0.05], duration=60.0).id
    queued = robot.ptwl(translation=[0.0, 0.0, -0.01], duration=1.0).id
    assert until(lambda: robot.get(running).status == "running", 2.0)  # it starts within a 2 ms batch
    yield robot, running, queued
    robot.stop()


def until(condition: Callable[[], bool], timeout_s: float) -> bool:
    """Poll `condition` every 10 ms; whether it came true within `timeout_s`."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


def assert_nothing_lost(robot: RobotClient, running: int, queued: int, sim_time_before: float) -> None:
    assert until(lambda: robot.health().sim_time > sim_time_before + 0.1, 2.0)  # still advancing
    health = robot.health()
    assert health.status == "ok"
    assert health.queued == 1
    assert robot.get(running).status == "running" and robot.get(queued).status == "queued"
    robot.stop()
    # 5 mm: past the 2 mm goal tolerance, so it must move; on the stiff preset (0.3 s time
    # constant) over 0.1 s the port arrives in ~0.35 s, not the ~0.95 s 10 mm took at the default
    # (45 cases).
    done = robot.run("ptwl", translation=[0.0, 0.0, -0.005], duration=0.1, preset="stiff", timeout=10)
    assert done.exit == "goal_reached"


@pytest.mark.parametrize("case", list(BAD_COMMANDS))
def test_bad_command_is_refused_and_nothing_is_lost(
    case: str, busy: tuple[RobotClient, int, int], server: ServiceProcess
) -> None:
    robot, running, queued = busy
    body, status, fragments = BAD_COMMANDS[case]
    before = robot.health().sim_time
    response = httpx.post(
        server.url + "/api/commands", content=body.encode(), headers={"content-type": "application/json"}
    )
    assert response.status_code == status, response.text
    detail = response.json()["detail"]
    for fragment in fragments:
        assert fragment in detail, detail
    assert_nothing_lost(robot, running, queued, before)


def test_unknown_scene_lists_the_valid_ones(
    busy: tuple[RobotClient, int, int], server: ServiceProcess
) -> None:
    robot, running, queued = busy
    before = robot.health().sim_time
    response = httpx.post(server.url + "/api/scene", json={"name": "moon"})
    assert response.status_code == 422
    assert response.json()["detail"] == f"name: unknown scene 'moon'; valid: {', '.join(sorted(SCENES))}"
    assert_nothing_lost(robot, running, queued, before)


@pytest.mark.parametrize(
    ("body", "fragments"),
    [
        ({"name": "surface", "seed": -1}, ["seed", "greater than or equal to 0"]),
        ({"name": "surface", "seed": 2**40}, ["seed", "less than or equal to 4294967295"]),
        ({"name": "surface", "seed": "7"}, ["seed", "valid integer"]),
        ({"name": "surface", "sede": 7}, ["sede", "Extra inputs"]),
        (
            {"name": "surface", "gripper_close_s": 0.01},
            ["gripper_close_s: the surface scene's tool has no gripper"],
        ),
        (
            {"name": "door", "gripper_close_s": 0.01},
            ["gripper_close_s: the door scene's gripper holds its part from the start"],
        ),
        (
            {"name": "tool_retrieval", "gripper_close_s": 0.001},
            ["gripper_close_s", "must be in [0.002, 0.05] s, got 0.001"],
        ),
        (
            {"name": "tool_retrieval", "gripper_close_s": 0.5},
            ["gripper_close_s", "must be in [0.002, 0.05] s, got 0.5"],
        ),
        ({"name": "tool_retrieval", "gripper_close_s": "0.01"}, ["gripper_close_s", "valid number"]),
    ],
)
def test_bad_scene_reset_is_refused_before_it_stops_anything(
    busy: tuple[RobotClient, int, int], server: ServiceProcess, body: dict[str, object], fragments: list[str]
) -> None:
    """A reset stops everything, so it must be judged whole first: seed -1 used to abort the
    running command and drop the queue, then answer 500."""
    robot, running, queued = busy
    before = robot.health().sim_time
    response = httpx.post(server.url + "/api/scene", json=body)
    assert response.status_code == 422, response.text
    for fragment in fragments:
        assert fragment in response.json()["detail"]
    assert_nothing_lost(robot, running, queued, before)


def test_huge_dither_axis_is_a_direction_not_a_fault(robot: RobotClient) -> None:
    """1.3e154 squared overflows a naive norm; the axis is a direction, normalized once."""
    robot.stop()
    done = robot.run("dither", axis=[1.3e154, 0.0, 1.3e154], travel=0.002, duration=0.5, timeout=15)
    assert done.exit == "goal_reached", done
    assert done.params["axis"] == pytest.approx([2**-0.5, 0.0, 2**-0.5])
    assert robot.health().faults == 0


def test_bad_long_poll_wait(busy: tuple[RobotClient, int, int], server: ServiceProcess) -> None:
    robot, running, queued = busy
    before = robot.health().sim_time
    response = httpx.get(f"{server.url}/api/commands/{running}", params={"wait": 100})
    assert response.status_code == 422 and "wait" in response.json()["detail"]
    assert_nothing_lost(robot, running, queued, before)


def test_queue_is_bounded_with_429(robot: RobotClient, server: ServiceProcess) -> None:
    running = robot.ptwl(translation=[0.0, 0.0, -0.05], duration=60.0).id
    ids = [robot.ptwl(translation=[0.0, 0.0, -0.01], duration=1.0).id for _ in range(64)]
    response = httpx.post(server.url + "/api/commands", json={"type": "rwe"})
    assert response.status_code == 429 and response.headers["retry-after"] == "1"
    assert "queue is full (64 queued)" in response.json()["detail"]
    assert robot.health().queued == 64 and robot.get(running).status == "running"
    result = robot.stop()
    assert result.aborted == running and sorted(result.dropped) == ids
    assert robot.run("rwe", duration=0.2, timeout=10).exit == "completed"
