"""Commands through a real uvicorn server: exits, order, long-poll, stop, scenes, task, OpenAPI."""

import itertools
import threading
import time

import httpx
import numpy as np
import pytest

from robot_sim.scenes import SCENES
from robot_sim.scenes.grasp import PNEUMATIC_CLOSE_S
from server.client import RobotClient, RobotError
from tests.command_line import run_ptwl

GAP_TO_PLATE = 0.0466 - 0.008  # [m] as in tests/test_ptwl.py


def collect_telemetry(robot: RobotClient, seconds: float) -> tuple[list[dict], threading.Thread]:
    messages: list[dict] = []

    def read() -> None:
        end = time.monotonic() + seconds
        for message in robot.telemetry():
            messages.append(message)
            if time.monotonic() > end:
                return

    thread = threading.Thread(target=read, daemon=True)
    thread.start()
    time.sleep(0.3)  # connected and receiving
    return messages, thread


def test_ptwl_in_free_space_reaches_goal_and_telemetry_shows_the_port_following(robot: RobotClient) -> None:
    messages, reader = collect_telemetry(robot, seconds=3.5)
    start = np.array(robot.state().port.position)
    done = robot.run("ptwl", translation=[0.0, 0.0, -0.04], duration=1.5, timeout=10)
    reader.join(10)
    assert done.exit == "goal_reached"
    states = [m for m in messages if m["type"] == "state" and m["active_command"] == done.id]
    assert len(states) > 50
    port_z = np.array([s["port"]["position"][2] for s in states])
    attractor_z = np.array([s["attractor"]["position"][2] for s in states])
    # Tool z points down, so -0.04 in the tool frame is up. The attractor leads, the port follows.
    assert attractor_z[-1] == pytest.approx(start[2] + 0.04, abs=1e-4)
    assert port_z[-1] == pytest.approx(start[2] + 0.04, abs=0.003)  # last message before the exit
    assert done.final_port is not None
    assert done.final_port.position[2] == pytest.approx(start[2] + 0.04, abs=0.002)  # the tolerance
    assert np.all(np.diff(port_z) > -1e-5)  # monotonic: a first-order lag, no overshoot
    assert np.all(attractor_z[: len(attractor_z) // 2] >= port_z[: len(port_z) // 2] - 1e-6)
    events = [m for m in messages if m["type"] == "command" and m["id"] == done.id]
    assert [e["status"] for e in events] == ["queued", "running", "done"]
    assert events[-1]["exit"] == "goal_reached"


def test_ptwl_into_the_surface_breaches_near_the_threshold(robot: RobotClient) -> None:
    robot.reset_scene("surface")
    done = robot.run(
        "ptwl", translation=[0, 0, GAP_TO_PLATE + 0.04], duration=8.0, force_threshold=15.0, timeout=20
    )
    assert done.exit == "wrench_breach"
    assert done.peak_force == pytest.approx(15.0, rel=0.1)
    assert done.final_wrench is not None and done.final_wrench[2] > 10.0
    assert robot.task().scene == "surface"


def test_stop_aborts_the_running_command_and_drops_the_queue(robot: RobotClient) -> None:
    first = robot.ptwl(translation=[0.05, 0, 0], duration=5.0)
    queued = [robot.ptwl(translation=[0.0, 0.01, 0], duration=1.0) for _ in range(3)]
    time.sleep(0.5)
    result = robot.stop()
    assert result.aborted == first.id
    assert sorted(result.dropped) == [q.id for q in queued]
    assert robot.get(first.id).exit == "aborted"
    assert all(robot.get(q.id).exit == "aborted" and robot.get(q.id).started_at is None for q in queued)
    held = np.array(robot.state().port.position)
    time.sleep(1.0)
    assert np.linalg.norm(np.array(robot.state().port.position) - held) < 0.003  # holds where it is
    assert robot.health().queued == 0


def test_commands_run_in_order_one_at_a_time(robot: RobotClient) -> None:
    ids = [robot.ptwl(translation=[0.0, 0.0, -0.005 * (i + 1)], duration=0.3).id for i in range(4)]
    finished = [robot.wait(i, timeout=20) for i in ids]
    assert all(f.exit == "goal_reached" for f in finished)
    for before, after in itertools.pairwise(finished):
        assert before.ended_at is not None and after.started_at is not None
        assert after.started_at >= before.ended_at
    listed = [c.id for c in robot.commands(limit=4)]
    assert listed == ids  # newest last


def test_long_poll_answers_when_done_and_times_out_otherwise(robot: RobotClient) -> None:
    cmd = robot.ptwl(translation=[0.0, 0.0, -0.01], duration=0.5)
    t0 = time.monotonic()
    status = robot.get(cmd.id, wait=0.1)
    assert status.status == "running" and time.monotonic() - t0 >= 0.1
    done = robot.get(cmd.id, wait=20.0)
    assert done.status == "done" and time.monotonic() - t0 < 5.0
    with pytest.raises(RobotError) as err:
        robot.get(10**6)
    assert err.value.status_code == 404


def test_waiting_outlasts_the_clients_own_read_timeout(server) -> None:  # type: ignore[no-untyped-def]
    """A long-poll is held by the server for up to its `wait`: the client's read timeout must
    stretch by that much (it did not: any command over 10 s raised ReadTimeout in `wait`)."""
    with RobotClient(server.url, timeout=1.0) as client:
        client.reset_scene("free_space")
        done = client.run("ptwl", translation=[0.0, 0.0, -0.02], duration=2.5)
    assert done.status == "done" and done.exit == "goal_reached" and (done.duration or 0.0) > 2.0


def test_watchdog_ends_a_command_nobody_asks_about(robot: RobotClient) -> None:
    robot.reset_scene("surface")
    # Behind the plate, under the threshold: only the watchdog can end it.
    cmd = robot.ptwl(
        translation=[0, 0, GAP_TO_PLATE + 0.004], duration=0.5, force_threshold=50.0, watchdog=1.5
    )
    time.sleep(2.5)
    status = robot.get(cmd.id)
    assert status.status == "done" and status.exit == "timeout"
    assert status.duration == pytest.approx(1.5, abs=0.01)


def test_scene_reset_with_seed_and_task(robot: RobotClient) -> None:
    robot.reset_scene("sleeve_on_peg", seed=4)
    task = robot.task()
    assert task.scene == "sleeve_on_peg" and not task.success
    assert task.progress == pytest.approx(-0.0206, abs=0.003)
    assert robot.state().scene == "sleeve_on_peg"
    assert [s.name for s in robot.scenes()] == list(SCENES)


def test_a_reset_sets_the_grippers_closing_time_and_the_geometry_says_it(robot: RobotClient) -> None:
    robot.reset_scene("tool_retrieval", seed=1, gripper_close_s=PNEUMATIC_CLOSE_S)
    pneumatic = robot.geometry()
    assert pneumatic.scene == "tool_retrieval" and pneumatic.gripper_close_s == PNEUMATIC_CLOSE_S
    robot.reset_scene("tool_retrieval", seed=1)  # not carried into the next load: the scene's own
    assert robot.geometry().gripper_close_s == pytest.approx(0.01)
    robot.reset_scene("surface")
    assert robot.geometry().gripper_close_s is None  # a probe, no gripper


def test_presets_by_name(robot: RobotClient) -> None:
    presets = robot.presets()
    assert presets["medium"]["stiffness"] == [2000, 2000, 2000, 100, 100, 100]
    assert set(presets["dither"]) == {
        "torsional_push",
        "torsional_pull",
        "translational_push",
        "translational_pull",
    }
    done = robot.run("ptwl", translation=[0, 0, -0.01], preset="stiff", timeout=10)
    assert done.exit == "goal_reached" and done.params["preset"] == "stiff"
    done = robot.run("dither", preset="translational_pull", travel=0.005, timeout=20)
    assert done.exit == "goal_reached" and done.params["mode"] == "translational"


def test_openapi_documents_every_parameter_with_units(server) -> None:  # type: ignore[no-untyped-def]
    spec = httpx.get(server.url + "/openapi.json").json()
    schemas = spec["components"]["schemas"]
    for name in (
        "PtwlParams",
        "RweParams",
        "DitherParams",
        "CommandStatus",
        "RobotStateModel",
        "HealthModel",
    ):
        for field, prop in schemas[name]["properties"].items():
            assert prop.get("description"), f"{name}.{field} has no description"
    assert "[s]" in schemas["PtwlParams"]["properties"]["duration"]["description"]
    assert "[N]" in schemas["PtwlParams"]["properties"]["force_threshold"]["description"]
    assert httpx.get(server.url + "/docs").status_code == 200


def test_api_docs_example_script_drives_a_ptwl_rwe_sequence(server) -> None:  # type: ignore[no-untyped-def]
    result = run_ptwl("--url", server.url, module="ptwl.experiments.press_and_relieve", timeout=120)
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[0].startswith("press") and "wrench_breach" in lines[0]
    assert lines[1].startswith("relieve") and "completed" in lines[1]
    assert lines[2].startswith("back off") and "goal_reached" in lines[2]


def test_geometry_and_body_poses_let_a_client_draw_the_scene(robot: RobotClient) -> None:
    robot.reset_scene("sleeve_on_peg")
    geometry = robot.geometry()
    assert geometry.scene == "sleeve_on_peg"
    kinds = {g.type for g in geometry.geoms}
    assert {"box", "cylinder", "mesh", "plane"} <= kinds
    chamfer = next(g for g in geometry.geoms if g.name == "peg_chamfer")
    assert chamfer.vertices and chamfer.faces and len(chamfer.vertices) == 48
    assert sum(1 for g in geometry.geoms if g.body == "arm/tool/tool") >= 16  # the sleeve's walls
    moving = {name for name, body in geometry.bodies.items() if body.moving}
    assert {"arm/link1", "arm/link6", "arm/tool/tool"} <= moving and "peg_base" not in moving
    state = robot.state()
    assert set(state.bodies) == moving
    # The tool body and the port (on it) agree: the port is 96 mm along the tool's z.
    tool = np.array(state.bodies["arm/tool/tool"][0:3])
    assert np.linalg.norm(tool - np.array(state.port.position)) == pytest.approx(0.096, abs=1e-3)


def test_a_fast_approach_is_accepted_with_a_warning(robot: RobotClient) -> None:
    fast = robot.command("ptwl", translation=[0.0, 0.0, 0.1], duration=1.0, force_threshold=15.0)
    assert len(fast.warnings) == 1 and "force_threshold 15 N" in fast.warnings[0]
    slow = robot.command("ptwl", translation=[0.0, 0.0, 0.01], duration=5.0, force_threshold=15.0)
    assert slow.warnings == []
    robot.stop()
    assert robot.state().limited is None  # at home nothing holds the arm back


def test_a_move_within_its_tolerance_is_accepted_with_a_warning_and_ends_without_moving(
    robot: RobotClient,
) -> None:
    """Issue 27: a 1.6 mm PTWL with the 2 mm default tolerance ended goal_reached in 0.00 s
    without moving, and nothing said it would."""
    small = robot.command("ptwl", translation=[0.0016, 0.0, 0.0], duration=1.0)
    (warning,) = small.warnings
    assert warning.startswith("the move (1.6 mm, 0 deg) is within its tolerances (2 mm, 1.15 deg)")
    done = robot.wait(small.id, timeout=5.0)
    assert done.exit == "goal_reached" and done.duration is not None and done.duration < 0.05
    below = robot.command("ptwl", translation=[0.0016, 0.0, 0.0], duration=1.0, position_tolerance=0.0005)
    assert below.warnings == []  # a tolerance under the move: it moves
    assert robot.command("ptwl", translation=[0.0, 0.0, 0.0], duration=0.5).warnings == []  # gains only
    robot.stop()
