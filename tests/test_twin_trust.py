"""When the ghost can be believed (issue 27.4), on hand-set clocks. On main, after a reset the
readout said "off 0.8 mm" with the ghost 60 mm from the port; under load it froze for ~4 s
still saying "off 0.0 mm"; after STOP it drew the aborted move going on."""

import pytest

from robot_sim.params import PtwlParams
from robot_sim.sim import Simulation
from robot_sim.telemetry import state_fields
from web.twin import GroundTwin, Prediction, Sent
from web.twin_trust import TwinTrust, ghost_label, judge_twin, twin_readout


def test_the_ghost_is_sure_only_when_fresh_judged_and_no_stop_is_pending() -> None:
    """In the rule's own numbers: behind by over 0.2 s, or nothing judged for over 1 s."""
    now = 1000.0
    assert judge_twin(now, now - 0.02, now - 0.05, None).sure
    lagging = judge_twin(now, now - 0.25, now - 0.05, None)
    assert not lagging.sure and lagging.reason == "0.2 s behind (the machine is busy)"
    assert judge_twin(now, now - 0.19, now - 0.05, None).sure
    unjudged = judge_twin(now, now - 0.02, now - 1.5, None)
    assert not unjudged.sure and unjudged.reason == "not judged for 1.5 s"
    assert judge_twin(now, now - 0.02, now - 0.99, None).sure
    assert judge_twin(now, now - 0.02, now - 1.0, None).sure  # a second ago exactly: still within
    assert not judge_twin(now, now - 0.02, now - 1.01, None).sure
    assert judge_twin(now, now - 0.02, None, None).reason == "not judged yet"
    stopping = judge_twin(now, now - 0.02, now - 0.05, now - 2.0)
    assert not stopping.sure and stopping.reason == "STOP sent 2.0 s ago, not confirmed yet"


def feed(twin: GroundTwin, robot: Simulation, wall: float, steps: int = 10) -> float:
    """The robot's states every 20 ms for `steps`, each arriving at once, the twin advanced
    after each (an uplink of 0.1 s: the twin leads, and each state judges a prediction); the
    wall time after."""
    for _ in range(steps):
        for _ in range(20):
            robot.step()
        wall += 0.02
        twin.on_state({**state_fields(robot, []), "sent_at": wall, "taken_at": wall}, wall)
        twin.advance(wall)
    return wall


def test_a_reset_forgets_the_old_scenes_judgment_until_the_new_one_is_judged() -> None:
    twin = GroundTwin(lambda: 0.1)
    robot = Simulation("free_space")
    wall = feed(twin, robot, 1000.0, 30)
    trust, readout = twin_readout(wall, twin)
    assert trust.sure and readout.startswith("off 0.0 mm")
    robot = Simulation("free_space")  # a reset: sim time starts again
    for _ in range(20):
        robot.step()
    twin.on_state({**state_fields(robot, []), "sent_at": wall + 0.02, "taken_at": wall + 0.02}, wall + 0.02)
    trust, readout = twin_readout(wall + 0.03, twin)
    assert not trust.sure and readout == "UNSURE: not judged yet"  # not the old scene's 0.0 mm
    wall = feed(twin, robot, wall + 0.02, 30)
    assert twin_readout(wall, twin)[0].sure


def test_after_stop_the_ghost_is_unsure_until_the_robot_confirms() -> None:
    twin = GroundTwin(lambda: 0.1)
    robot = Simulation("free_space")
    wall = feed(twin, robot, 1000.0, 30)
    twin.on_stop(wall)
    wall = feed(twin, robot, wall, 5)
    trust, readout = twin_readout(wall, twin)
    assert not trust.sure and readout.startswith(
        "UNSURE: STOP sent 0.1 s ago, not confirmed yet (last judged: off"
    )
    twin.on_stop_confirmed(None)
    assert twin_readout(wall, twin)[0].sure


def test_a_twin_that_stopped_advancing_says_how_far_behind_it_is() -> None:
    twin = GroundTwin(lambda: 0.1)
    wall = feed(twin, Simulation("free_space"), 1000.0, 30)
    trust, readout = twin_readout(wall + 0.9, twin)  # nothing advanced it for 0.9 s
    assert not trust.sure and readout.startswith("UNSURE: 0.9 s behind (the machine is busy)")
    assert pytest.approx(wall) == twin.advanced_wall


def test_the_ghosts_own_label_is_short_and_says_unsure() -> None:
    """It floats in the view (a long reason ran under the control panel); the bar says why."""
    assert (
        ghost_label(TwinTrust(True), "off 0.3 mm (max 0.9 over 5 s)")
        == "predicted · off 0.3 mm (max 0.9 over 5 s)"
    )
    unsure = ghost_label(TwinTrust(False, "STOP sent 2.8 s ago"), "UNSURE: STOP sent 2.8 s ago")
    assert unsure == "predicted · UNSURE (the status bar says why)"


MOVE = PtwlParams(translation=[0.0, 0.08, 0.0], frame="base", duration=1.0)  # 80 mm along base y


def settled_twin() -> tuple[GroundTwin, Simulation, float, Prediction]:
    """A twin fed 0.6 s of a robot at rest: (twin, robot, wall clock, its prediction now)."""
    twin = GroundTwin(lambda: 0.1)
    robot = Simulation("free_space")
    wall = feed(twin, robot, 1000.0, 30)
    still = twin.advance(wall)
    assert still is not None
    return twin, robot, wall, still


def test_stop_drops_the_commands_this_console_sent_from_the_prediction() -> None:
    """A STOP means this console's queued sends will not run: the twin stops predicting them at
    once (its next tick), before the robot says anything."""

    twin, _, wall, still = settled_twin()
    twin.on_sent(Sent(MOVE, wall, lambda: True))
    moving = twin.advance(wall + 0.3)
    assert moving is not None and moving.port[0][1] - still.port[0][1] > 0.005  # predicted moving
    twin.on_stop(wall + 0.3)
    stopped = twin.advance(wall + 0.32)  # the next tick, not the next periodic restart
    assert stopped is not None and abs(stopped.port[0][1] - still.port[0][1]) < 0.001  # the robot's own


def test_a_confirmed_stop_ends_the_replay_of_the_move_it_aborted() -> None:
    """The running command's event is replayed at each restart until its end is heard; a
    confirmed STOP that names it ends the replay (its own end event may be lost)."""
    twin, robot, wall, still = settled_twin()
    port = robot.state().port
    goal = {
        "position": [port.position[0], port.position[1] + 0.08, port.position[2]],
        "quaternion": list(port.quaternion),
    }
    twin.on_command(
        {
            "id": 7,
            "status": "running",
            "behavior": "ptwl",
            "params": MOVE.model_dump(),
            "goal": goal,
            "started_at": wall,
        }
    )
    twin.pause()  # replayed from the next restart, as at each restart until its end is heard
    replayed = twin.advance(wall + 0.3)
    assert replayed is not None and replayed.port[0][1] - still.port[0][1] > 0.005
    twin.on_stop(wall + 0.3)
    twin.on_stop_confirmed(7)
    after = twin.advance(wall + 0.35)
    assert after is not None and abs(after.port[0][1] - still.port[0][1]) < 0.001
