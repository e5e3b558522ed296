"""Preview before Send (issue 14): a contemplated command run to its exit on a copy of the model
from the twin's state, in well under a second for a 10 s command, matching what the robot does."""

import time

import numpy as np
import pytest

from robot_sim.behaviors import ExitCondition, behavior_for
from robot_sim.params import PtwlParams
from robot_sim.sim import Simulation
from robot_sim.task_frames import TaskFrame, unit_quaternion
from tests.helpers import PREVIEW_WALL_BOUND_S
from web.preview import Previewer
from web.twin import TwinPoint
from web.twin_sim import point_from_sim


def point(sim: Simulation) -> TwinPoint:
    return point_from_sim(sim, sim.frames, busy=False)


def test_a_10_s_move_is_previewed_in_under_a_second_and_goes_where_the_robot_goes() -> None:
    robot = Simulation("free_space")
    move = PtwlParams(translation=[0.05, -0.08, 0.03], frame="base", duration=10.0)
    previewer = Previewer()
    previewer.run(point(robot), PtwlParams(duration=0.1))  # the model is built once per scene
    cpu0_s = time.thread_time()
    preview = previewer.run(point(robot), move)
    cpu_s = time.thread_time() - cpu0_s
    # Under a second of computing, and the wall time it reports is that computing's. CPU time,
    # with wall time only bounded: beside other tests a busy machine made the same 0.2 s preview
    # take 1.44 s of wall (the wall figure alone is `python -m bench.twin`'s `preview_10s_move`).
    assert cpu_s < 1.0
    assert 0.9 * cpu_s <= preview.compute_s < PREVIEW_WALL_BOUND_S
    report = robot.run_behavior(behavior_for(move))
    assert preview.exit == report.exit.value == "goal_reached"
    assert preview.duration_s == pytest.approx(report.duration, abs=0.05)
    np.testing.assert_allclose(preview.port_path[-1], report.final_port.position, atol=1e-4)
    np.testing.assert_allclose(preview.attractor_path[0], robot.state().port.position, atol=0.1)  # a path
    assert len(preview.port_path) > 400  # 20 ms points over ~10 s


def test_a_move_in_a_task_frame_previews_where_the_robot_goes() -> None:
    """The preview uses the robot's frames as the console heard them, not the nominal scene's."""
    robot = Simulation("free_space")
    robot.frames.add(
        TaskFrame("leaning", (0.4, 0.0, 0.3), unit_quaternion([0.9, 0.3, 0.2, 0.0]), "operator", "")
    )
    move = PtwlParams(translation=[0.0, 0.03, 0.02], frame="leaning", duration=1.5)
    preview = Previewer().run(point(robot), move)
    report = robot.run_behavior(behavior_for(move))
    assert preview.exit == report.exit.value == "goal_reached"
    np.testing.assert_allclose(preview.port_path[-1], report.final_port.position, atol=1e-4)


def test_a_press_into_the_plate_previews_its_breach_and_peak_force() -> None:
    robot = Simulation("surface")
    press = PtwlParams(
        translation=[0, 0, -0.06], frame="base", duration=2.0, force_threshold=15.0, on_breach="freeze"
    )
    preview = Previewer().run(point(robot), press)
    report = robot.run_behavior(behavior_for(press))
    assert preview.exit == report.exit.value == ExitCondition.WRENCH_BREACH.value
    assert preview.peak_force_n == pytest.approx(report.peak_force, rel=0.02) and preview.peak_force_n > 15.0
