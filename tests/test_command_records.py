"""Command records every reader can trust (issue 9, holes 4 and 5): ids that never repeat across
restarts, an instance id with each, and no NaN leaving the server."""

import dataclasses
import json
import math
import threading
import time
from typing import Any

import httpx
import pytest
import websockets.sync.client

from ptwl.launcher import ServiceProcess, free_port, running_server
from robot_sim.behaviors import ExitCondition, behavior_for
from robot_sim.machines.command import StateMachineParams
from robot_sim.params import RweParams
from robot_sim.policies.run import StepRecord
from robot_sim.sim import Simulation
from server.client import RobotClient
from server.commands import CommandBook


def strict_json(text: str) -> Any:
    """json.loads that refuses NaN and Infinity, as a browser's JSON.parse does."""

    def refuse(token: str) -> None:
        raise ValueError(f"not JSON: {token}")

    return json.loads(text, parse_constant=refuse)


def test_ids_never_repeat_across_a_restart_and_the_instance_says_which_run() -> None:
    port = free_port()
    with running_server("--scene", "free_space", port=port) as first, RobotClient(first.url) as robot:
        before = robot.health().instance
        old = [robot.run("rwe", duration=0.05, timeout=10) for _ in range(3)]
    with running_server("--scene", "free_space", port=port) as second, RobotClient(second.url) as robot:
        after = robot.health().instance
        accepted = robot.rwe(duration=0.05)
        new = robot.wait(accepted.id, timeout=10)
        assert robot.state().instance == after
    assert before != after and len(after) == 8
    assert {c.instance for c in old} == {before} and new.instance == accepted.instance == after
    assert [c.id for c in old] == sorted(c.id for c in old)
    assert new.id > max(c.id for c in old)  # on main: 1 again, and a console took it for the old #1
    assert new.id < 2**53  # exact in a JavaScript number


def test_command_events_carry_the_instance(robot: RobotClient) -> None:
    events: list[dict[str, Any]] = []
    instance = robot.health().instance

    def listen() -> None:
        for message in robot.telemetry():
            if message["type"] == "command":
                events.append(message)
            if len(events) >= 3:
                return

    listener = threading.Thread(target=listen, daemon=True)
    listener.start()
    time.sleep(0.3)
    accepted = robot.rwe(duration=0.05)
    listener.join(10.0)
    assert [e["status"] for e in events] == ["queued", "running", "done"]
    assert all(e["id"] == accepted.id and e["instance"] == instance for e in events)


def test_a_faulted_command_is_a_valid_record_for_every_reader(server: ServiceProcess) -> None:
    """A fault poisons the physics with NaN; the record's report fields are sanitised at the source."""
    with RobotClient(server.url) as robot:
        robot.reset_scene("free_space")
        url = robot.telemetry_url()
        with websockets.sync.client.connect(url) as ws:
            cmd = robot.ptwl(translation=[0.05, 0.0, 0.0], duration=5.0)
            time.sleep(0.3)
            httpx.post(server.url + "/api/_debug/fault").raise_for_status()
            done_event = None
            deadline = time.monotonic() + 10.0
            while done_event is None and time.monotonic() < deadline:
                message = strict_json(str(ws.recv(timeout=5.0)))  # every message, not only this one
                if message["type"] == "command" and message["id"] == cmd.id and message["status"] == "done":
                    done_event = message
        assert done_event is not None and done_event["exit"] == "fault"
        raw = strict_json(httpx.get(f"{server.url}/api/commands/{cmd.id}").text)
        for record in (raw, done_event):
            wrench = record["final_wrench"]
            assert wrench is None or all(math.isfinite(v) for v in wrench)
            if wrench is None:
                assert "non-finite" in record["detail"]
        # The client reads it, and the list around it, and waits on it.
        assert robot.get(cmd.id).exit == "fault"
        assert any(c.id == cmd.id for c in robot.commands())
        assert robot.wait(cmd.id, timeout=1.0).exit == "fault"


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_non_finite_report_fields_become_null_with_a_reason(value: float) -> None:
    book = CommandBook(4, 10)
    record = book.submit(RweParams(duration=0.01))
    with book.held() as held:
        held.start_next(lambda record: None, 0.0)
    real = Simulation("free_space").run_behavior(behavior_for(RweParams(duration=0.01)))
    poisoned = dataclasses.replace(real, final_wrench=(0.0, value, 0.0, 0.0, 0.0, 0.0), peak_force=value)
    with book.held() as held:
        held.finish(poisoned)
    model = book.get(record.id)
    assert model is not None
    assert model.final_wrench is None and model.peak_force is None
    assert model.peak_torque == real.peak_torque and "non-finite" in model.detail
    strict_json(model.model_dump_json())


def test_a_state_machine_step_that_faulted_is_valid_json_too() -> None:
    book = CommandBook(4, 10)
    record = book.submit(StateMachineParams(task="sleeve_on_peg"))
    with book.held() as held:
        held.start_next(lambda record: None, 0.0)
    real = Simulation("free_space").run_behavior(behavior_for(RweParams(duration=0.01)))
    nan = dataclasses.replace(
        real, final_wrench=(math.nan,) * 6, peak_force=math.inf, exit=ExitCondition.FAULT
    )
    with book.held() as held:
        held.step_done(StepRecord(0, RweParams(duration=0.01), "relieve", nan))
    model = book.get(record.id)
    assert model is not None and model.status == "running" and len(model.steps) == 1
    step = model.steps[0]
    assert step.final_wrench is None and step.peak_force is None and step.exit == "fault"
    strict_json(model.model_dump_json())
