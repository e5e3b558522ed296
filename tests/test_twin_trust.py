"""When the ghost can be believed (issue 27.4), on hand-set clocks. On main, after a reset the
readout said "off 0.8 mm" with the ghost 60 mm from the port; under load it froze for ~4 s
still saying "off 0.0 mm"; after STOP it drew the aborted move going on."""

import pytest

from robot_sim.sim import Simulation
from robot_sim.telemetry import state_fields
from web.twin import GroundTwin
from web.twin_trust import JUDGED_WITHIN_S, LAG_LIMIT_S, TwinTrust, ghost_label, judge_twin, twin_readout


def test_the_ghost_is_sure_only_when_fresh_judged_and_no_stop_is_pending() -> None:
    now = 1000.0
    assert judge_twin(now, now - 0.02, now - 0.05, None).sure
    lagging = judge_twin(now, now - LAG_LIMIT_S - 0.05, now - 0.05, None)
    assert not lagging.sure and lagging.reason == "0.2 s behind (the machine is busy)"
    assert judge_twin(now, now - LAG_LIMIT_S + 0.01, now - 0.05, None).sure
    unjudged = judge_twin(now, now - 0.02, now - JUDGED_WITHIN_S - 0.5, None)
    assert not unjudged.sure and unjudged.reason == "not judged for 1.5 s"
    assert judge_twin(now, now - 0.02, now - JUDGED_WITHIN_S + 0.01, None).sure
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
