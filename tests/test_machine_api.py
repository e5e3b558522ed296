"""Machines through a real uvicorn server: a machine given whole, its refusal naming the state and
field, its pending decision in the command's status and in telemetry, the decision route (409
for a late answer, 422 for a malformed one), and GET /api/tasks saying which machines are data."""

import time
from typing import Any

import pytest

from server.client import RobotClient, RobotError
from tests.test_autonomy import press_machine


def until_pending(robot: RobotClient, command_id: int, timeout_s: float = 15.0) -> dict[str, Any]:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        status = robot.get(command_id)
        if status.machine and status.machine.get("pending"):
            return status.machine
        assert status.status != "done", status
        time.sleep(0.05)
    raise AssertionError("no decision became pending")


def test_a_bad_machine_is_refused_naming_the_state_and_field(robot: RobotClient) -> None:
    machine = press_machine().model_dump(exclude_none=True)
    machine["states"]["relieve"]["command"]["duration"] = 700.0
    with pytest.raises(RobotError) as refused:
        robot.command("state_machine", machine=machine)
    assert refused.value.status_code == 422
    assert "states.relieve.command.duration: must be in (0, 600] s, got 700" in str(refused.value.detail)
    machine = press_machine().model_dump(exclude_none=True)
    machine["states"]["press"]["transitions"] = [{"on": ["timeout"], "to": "relieve"}]
    with pytest.raises(RobotError, match=r"states\.press\.transitions: nothing takes exit 'goal_reached'"):
        robot.command("state_machine", machine=machine)
    with pytest.raises(RobotError, match="needs scene surface"):  # its task names its scene
        robot.reset_scene("free_space")
        robot.command("state_machine", machine=press_machine().model_dump(exclude_none=True))


def test_a_pending_decision_is_in_the_status_and_telemetry_and_answered_by_number(robot: RobotClient) -> None:
    robot.reset_scene("surface")
    accepted = robot.command(
        "state_machine", machine=press_machine().model_dump(exclude_none=True), autonomy="high"
    )
    machine = until_pending(robot, accepted.id)
    pending = machine["pending"]
    assert (pending["decision"], pending["state"], pending["target"], pending["level"]) == (
        1,
        "press",
        "relieve",
        "high",
    )
    assert machine["name"] == "press_then_relieve" and machine["autonomy"] == "high"
    state = next(m for m in robot.telemetry() if m["type"] == "state")
    assert state["active_command"] == accepted.id
    assert state["machine"]["command"] == accepted.id and state["machine"]["pending"]["decision"] == 1
    with pytest.raises(RobotError) as late:
        robot.decide(accepted.id, decision=2, choice="confirm")
    assert late.value.status_code == 409 and "decision 2 is not the pending one (1)" in str(late.value.detail)
    with pytest.raises(RobotError) as malformed:
        robot.decide(accepted.id, decision=1, choice="force")
    assert malformed.value.status_code == 422 and "state: give it with choice `force`" in str(
        malformed.value.detail
    )
    with pytest.raises(RobotError) as other:
        robot.decide(accepted.id + 1_000_000, decision=1, choice="confirm")
    assert other.value.status_code == 404  # no such command
    with pytest.raises(RobotError) as invalid:
        robot.decide(accepted.id, decision=1, choice="force", state="presss")
    assert invalid.value.status_code == 422 and "no state 'presss' in press_then_relieve" in str(
        invalid.value.detail
    )
    with pytest.raises(RobotError) as never:
        robot.decide(accepted.id, decision=1, choice="outcome", outcome="completed")
    assert never.value.status_code == 422
    assert "a ptwl in state press ends goal_reached, wrench_breach, timeout, not 'completed'" in str(
        never.value.detail
    )
    answered = robot.decide(accepted.id, decision=1, choice="confirm")
    assert answered.machine is not None and answered.machine["pending"] is None
    done = robot.wait(accepted.id, timeout=15.0)
    assert done.exit == "completed"
    assert done.machine is not None and done.machine["decisions_waited"] == 1
    assert [h["how"] for h in done.machine["history"]] == ["confirm", "autonomous"]
    assert [s.state for s in done.steps] == ["press", "relieve"]


def test_the_task_list_gives_each_machine_written_as_data(robot: RobotClient) -> None:
    tasks = {t.name: t for t in robot.tasks()}
    assert tasks["plug"].machine is not None and tasks["plug"].machine["start"] == "approach"
    assert tasks["lid"].machine is None  # Python: no levels
