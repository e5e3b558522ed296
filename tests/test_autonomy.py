"""Autonomy levels on the robot (FlexBE's rule, robot_sim/executor.py): a transition whose level
is not below the run's waits onboard for the operator's decision, holding the attractor where
the step left it; the decision arrives across the link, numbered; confirm, another outcome,
force, stop and STOP all end the wait as they say. On the virtual clock (the sweeps' robot)."""

from typing import Any

import numpy as np
import pytest

from ptwl.experiments.sweep.operators import POLL_S
from ptwl.experiments.sweep.robot import Accepted, Asked, Decide, Done, Post, Refused, VirtualRobot
from ptwl.experiments.sweep.spec import TrialSpec
from ptwl.experiments.sweep.trial import simulate
from robot_sim.machines.command import DecisionRequest, StateMachineParams
from robot_sim.machines.spec import MachineSpec

GAP_M = 0.0466 - 0.008  # [m] the surface scene's plate below the port at home (tests/test_ptwl.py)
PRESS_M = GAP_M + 0.004  # the attractor 4 mm into the plate: ~8 N at `medium`'s 2000 N/m


def press_machine(level: str = "high") -> MachineSpec:
    """Press into the plate (it ends `timeout`, pressing steadily); then, at `level`, relieve."""
    return MachineSpec.model_validate(
        {
            "name": "press_then_relieve",
            "task": "surface",
            "start": "press",
            "states": {
                "press": {
                    "command": {
                        "type": "ptwl",
                        "translation": [0.0, 0.0, PRESS_M],
                        "duration": 1.0,
                        "watchdog": 2.0,
                        "force_threshold": 100.0,
                        "preset": "medium",
                    },
                    "transitions": [
                        {"on": ["timeout"], "to": "relieve", "autonomy": level},
                        {"to": "failed"},
                    ],
                },
                "relieve": {
                    "command": {"type": "rwe", "duration": 1.0},
                    "transitions": [{"to": "completed", "autonomy": "low"}],
                },
            },
        }
    )


def started(autonomy: str, level: str = "high") -> tuple[VirtualRobot, Asked]:
    """The machine sent to a robot on the surface scene, run to its first pending decision."""
    robot = VirtualRobot("surface", 0)
    params = StateMachineParams(machine=press_machine(level), autonomy=autonomy)  # type: ignore[arg-type]
    assert robot.handle(Post("op-1", params)) == Accepted("op-1")
    event = robot.tick_until(10.0)
    assert isinstance(event, Asked), event
    return robot, event


def force_n(robot: VirtualRobot) -> float:
    return float(np.linalg.norm(robot.sim.state().wrench[0:3]))


def machine_of(robot: VirtualRobot) -> dict[str, Any]:
    record = robot.submitted["op-1"]
    assert record.machine is not None
    return record.machine


def test_a_high_transition_under_low_autonomy_waits_holding_the_attractor_and_the_force() -> None:
    robot, asked = started("low")
    assert asked == Asked("op-1", 1)
    pending = machine_of(robot)["pending"]
    assert (pending["state"], pending["exit"], pending["target"], pending["level"]) == (
        "press",
        "timeout",
        "relieve",
        "high",
    )
    assert pending["next"]["type"] == "rwe" and pending["report"]["peak_force"] > 5.0
    asked_at = robot.sim.time
    attractor = robot.sim.state().attractor
    held = force_n(robot)
    assert 6.0 < held < 10.0  # ~8 N: 4 mm into the plate at 2000 N/m
    forces = []
    while robot.sim.time < asked_at + 5.0:  # nothing arrives: it waits, 5 s
        assert robot.tick(robot.sim.time + 0.1) is None
        forces.append(force_n(robot))
        assert robot.sim.behavior is None and robot.book.running is not None
    assert robot.sim.state().attractor == attractor  # not a nanometre of drift
    assert max(abs(f - held) for f in forces) <= 0.10 * held
    decided_at = robot.sim.time
    assert robot.handle(Decide("op-1", DecisionRequest(decision=1, choice="confirm"))) == Accepted("op-1")
    # The relieve's end is at `low`, not below `low`: it asks too.
    assert robot.tick_until(asked_at + 20.0) == Asked("op-1", 2)
    robot.handle(Decide("op-1", DecisionRequest(decision=2, choice="confirm")))
    done = robot.tick_until(robot.sim.time + 1.0)
    assert isinstance(done, Done) and done.outcome.exit == "completed"
    history = machine_of(robot)["history"]
    assert [(h["state"], h["target"], h["how"], h["level"]) for h in history] == [
        ("press", "relieve", "confirm", "high"),
        ("relieve", "completed", "confirm", "low"),
    ]
    assert decided_at - asked_at >= 5.0
    assert history[0]["waited_s"] == pytest.approx(decided_at - asked_at, abs=1e-9)
    assert machine_of(robot)["decisions_waited"] == 2


def test_below_the_runs_autonomy_nothing_waits() -> None:
    robot = VirtualRobot("surface", 0)
    params = StateMachineParams(machine=press_machine("high"), autonomy="full")  # type: ignore[arg-type]
    robot.handle(Post("op-1", params))
    done = robot.tick_until(20.0)
    assert isinstance(done, Done) and done.outcome.exit == "completed"
    machine = machine_of(robot)
    assert machine["decisions_waited"] == 0 and [h["how"] for h in machine["history"]] == [
        "autonomous",
        "autonomous",
    ]
    # Under `high`, only `full` and `high` wait: the press's end asks, the relieve's (low) does not.
    robot, _ = started("high")
    robot.handle(Decide("op-1", DecisionRequest(decision=1, choice="confirm")))
    done = robot.tick_until(robot.sim.time + 5.0)
    assert isinstance(done, Done) and done.outcome.exit == "completed"
    assert machine_of(robot)["decisions_waited"] == 1


def test_a_stale_or_unknown_decision_is_refused_and_the_wait_goes_on() -> None:
    robot, _ = started("low")
    reply = robot.handle(Decide("op-1", DecisionRequest(decision=2, choice="confirm")))
    assert isinstance(reply, Refused) and "decision 2 is not the pending one (1)" in reply.why
    assert machine_of(robot)["pending"]["decision"] == 1 and robot.sim.behavior is None
    reply = robot.handle(Decide("op-9", DecisionRequest(decision=1, choice="confirm")))
    assert isinstance(reply, Refused)


def test_forcing_a_state_goes_there_whatever_the_report_said() -> None:
    robot, _ = started("low")
    robot.handle(Decide("op-1", DecisionRequest(decision=1, choice="force", state="press")))
    assert robot.sim.behavior is not None and robot.sim.behavior.params.type == "ptwl"  # type: ignore[attr-defined]
    assert machine_of(robot)["history"][-1]["how"] == "force"
    reply = robot.handle(Decide("op-1", DecisionRequest(decision=1, choice="force", state="press")))
    assert isinstance(reply, Refused)  # taken: nothing pending now
    robot2, _ = started("low")
    robot2.handle(Decide("op-1", DecisionRequest(decision=1, choice="force", state="failed")))
    done = robot2.tick_until(robot2.sim.time + 1.0)
    assert isinstance(done, Done) and done.outcome.exit == "failed"
    assert "forced by the operator" not in done.outcome.detail  # `failed` forced: said as failed


def test_another_outcome_decides_as_if_the_behavior_had_ended_so() -> None:
    robot, _ = started("low")
    robot.handle(Decide("op-1", DecisionRequest(decision=1, choice="outcome", outcome="wrench_breach")))
    done = robot.tick_until(robot.sim.time + 1.0)  # press: wrench_breach goes to `failed`
    assert isinstance(done, Done) and done.outcome.exit == "failed"
    assert done.outcome.detail.startswith("press ended wrench_breach")


def test_stopping_mid_wait_ends_the_machine_aborted() -> None:
    robot, _ = started("low")
    robot.handle(Decide("op-1", DecisionRequest(decision=1, choice="stop")))
    done = robot.tick_until(robot.sim.time + 1.0)
    assert isinstance(done, Done) and done.outcome.exit == "aborted"
    assert "stopped by the operator at decision 1 (press)" in done.outcome.detail
    # STOP (POST /api/stop) while a decision waits: no behavior runs, the machine still ends.
    robot2, _ = started("low")
    stopped = robot2.stop()
    assert stopped.aborted is not None
    done = robot2.tick_until(robot2.sim.time + 1.0)
    assert isinstance(done, Done) and done.outcome.exit == "aborted"
    assert "stopped while decision 1 waited" in done.outcome.detail
    assert robot2.book.running is None


def test_over_the_link_a_decision_waits_exactly_the_round_trip_and_the_think_time() -> None:
    """The decision goes down (RTT/2), the operator thinks, the answer comes up (RTT/2): on the
    robot's clock each wait is RTT + that think time, to the 1 ms tick."""
    spec = TrialSpec("plug", "onboard", 3.0, 0.0, 0.0, 1, think_s=2.0, autonomy="high")
    trial = simulate(spec)
    record = next(iter(trial.robot.submitted.values()))
    assert record.machine is not None and record.exit == "completed"
    history = [h for h in record.machine["history"] if h["how"] == "confirm"]
    thinks = trial.operator.decision_thinks_s  # type: ignore[attr-defined]
    assert len(history) == len(thinks) == record.machine["decisions_waited"] >= 1
    for entry, think in zip(history, thinks, strict=True):
        assert entry["level"] == "high"
        assert entry["waited_s"] == pytest.approx(3.0 + think, abs=0.002)
    assert trial.robot.decision_wait_s == pytest.approx(sum(3.0 + t for t in thinks), abs=0.002 * len(thinks))


def test_a_lost_decision_event_is_found_by_the_operators_status_question() -> None:
    """Half the events lost (the decision's announcement among them): the operator asks for the
    command's status once it has waited its patience, learns of the pending decision from the
    answer, and confirms it; the trial completes as it would have, only later."""
    clean = simulate(TrialSpec("quick_connect", "onboard", 1.0, 0.0, 0.0, 0, autonomy="off"))
    lossy = simulate(TrialSpec("quick_connect", "onboard", 1.0, 0.0, 0.9, 0, autonomy="off"))
    assert clean.operator.end == lossy.operator.end == "completed"
    assert lossy.lost >= 2 and lossy.operator.requeries >= 2
    assert lossy.robot.decisions_waited == clean.robot.decisions_waited >= 2
    # Found by a status question, one patience later (the round trip + POLL_S): 14 s more here.
    assert lossy.robot.decision_wait_s > clean.robot.decision_wait_s + POLL_S


def test_a_refused_decision_leaves_the_wait_as_it_was() -> None:
    robot, _ = started("low")
    for bad in (
        DecisionRequest(decision=1, choice="force", state="nowhere"),
        DecisionRequest(decision=1, choice="outcome", outcome="completed"),  # a PTWL never ends so
    ):
        reply = robot.handle(Decide("op-1", bad))
        assert isinstance(reply, Refused)
        assert machine_of(robot)["pending"]["decision"] == 1 and robot.book.running is not None
    robot.handle(Decide("op-1", DecisionRequest(decision=1, choice="confirm")))
    assert robot.sim.behavior is not None  # the relieve runs


def test_a_physics_fault_while_a_decision_waits_ends_the_machine_fault() -> None:
    """The scene reloads at t = 0 after a fault: the machine must not go on in it (its
    variables and poses are of the old one); it ends `fault` and the queue is free."""
    robot, _ = started("low")
    robot.sim.data.qvel[0] = float("nan")  # the next step faults (server/runner.py's test hook)
    done = robot.tick_until(robot.sim.time + 1.0)
    assert isinstance(done, Done) and done.outcome.exit == "fault", done
    assert "the physics faulted while decision 1 waited (press)" in done.outcome.detail
    assert robot.book.running is None and robot.sim.fault_count == 1
    reply = robot.handle(Decide("op-1", DecisionRequest(decision=1, choice="confirm")))
    assert isinstance(reply, Refused)  # nothing waits any more


def test_stop_ends_a_machine_between_steps_even_with_nothing_pending() -> None:
    """Whatever left a machine between steps with no decision pending (a bug elsewhere), STOP
    still ends it and frees the queue: nothing can hold the robot's queue past a STOP."""
    robot, _ = started("low")
    run = robot.commands._executor.run  # the state a failed commit once left (an outside review)
    assert run is not None
    run.pending = None
    robot.stop()
    done = robot.tick_until(robot.sim.time + 1.0)
    assert isinstance(done, Done) and done.outcome.exit == "aborted"
    assert "stopped between steps" in done.outcome.detail and robot.book.running is None
