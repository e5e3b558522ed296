"""Controller properties: bumpless start, limits that slow instead of jump, determinism, faults."""

import math
import re
from typing import Any

import mujoco
import numpy as np
import pytest

from robot_sim.behaviors.base import ExitCondition
from robot_sim.behaviors.ptwl import Ptwl
from robot_sim.controller import JOINT_ACCEL_LIMIT, MANIPULABILITY_THRESHOLD
from robot_sim.errors import RobotSimError
from robot_sim.params import PtwlParams
from robot_sim.sim import Simulation
from tests.helpers import TEST_GAINS, fit_time_constant, step_response


def pressed_under_position_control(force_n: float) -> Simulation:
    """Jog the probe down onto the plate with compliance off, until the press reaches force_n."""
    sim = Simulation("surface")
    ctl = sim.controller
    ctl.disable()
    J = np.zeros((6, 6))
    mujoco.mj_jacSite(sim.model, sim.data, J[0:3], J[3:6], sim.layout.port_site)
    qdot = np.linalg.solve(J, [0, 0, -0.004, 0, 0, 0])  # 4 mm/s straight down: no impact spike
    sim.data.ctrl[0:6] = qdot
    sim.data.ctrl[6:12] = qdot
    for _ in range(15000):  # the plate is 38.6 mm below the tip
        sim.step()
        if ctl.w_world_env_on_port[2] > force_n:
            break
    else:
        raise AssertionError("the jog never reached the plate")
    sim.data.ctrl[:] = 0.0  # the servos hold the pose, and with it the press
    sim.run(0.3)
    return sim


def test_enabling_compliance_in_contact_is_bumpless() -> None:
    sim = pressed_under_position_control(12.0)
    ctl = sim.controller
    before = float(ctl.w_world_env_on_port[2])
    assert before > 8.0
    ctl.enable()
    # The attractor sits past the plate by w/K, so the first command is (nearly) still.
    stretch_z = ctl.stretch_world()[2]
    assert stretch_z == pytest.approx(-ctl.w_world_env_on_port[2] / ctl.gains.stiffness[2], rel=1e-9)
    assert stretch_z == pytest.approx(-before / ctl.gains.stiffness[2], rel=0.01)
    assert np.abs(ctl.twist_des()).max() < 1e-6
    forces = []
    for _ in range(1000):
        sim.step()
        forces.append(ctl.w_world_env_on_port[2])
    assert max(abs(f - before) for f in forces) < 0.05 * before


def test_a_naive_start_would_have_released_the_press() -> None:
    """Control for the test above: attractor on the port (not bumpless) lets the press go."""
    sim = pressed_under_position_control(12.0)
    ctl = sim.controller
    ctl.place_attractor_from_port(np.zeros(6))
    ctl.enabled = True
    sim.run(1.0)
    assert ctl.w_world_env_on_port[2] < 0.1 * 12.0


def test_joint_limit_is_approached_smoothly_never_hit() -> None:
    home = (0.0, 0.3, 0.2, 0.0, 1.0708, 6.85)  # joint 6 close to its +6.98 rad limit
    sim = Simulation("free_space", qpos=home)
    upper = sim.layout.joint_range[5, 1]
    report = sim.run_behavior(Ptwl(PtwlParams(rotation=[0, 0, 0.5], duration=1.0, watchdog=3.0)))
    q6 = sim.data.qpos[5]
    assert report.exit is ExitCondition.TIMEOUT
    assert "limited: joint_limit (" in report.detail  # says why it stopped short, and which joint
    assert "joint 6 at its upper end" in report.detail
    assert sim.state().limited == "joint_limit"
    assert upper - 0.05 < q6 < upper
    assert abs(sim.data.qvel[5]) < 1e-3


def test_stretching_past_reach_slows_down_at_the_singularity() -> None:
    sim = Simulation("free_space")
    vmax = sim.layout.joint_speed_limit
    # 0.63 m at 0.3 m/s toward a point out of reach: the arm runs into the stretched-out singularity.
    params = PtwlParams(translation=[0.6, 0.0, 0.2], frame="base", duration=2.0, watchdog=4.0)
    sim.start(Ptwl(params))
    manipulability, peak_speed, peak_accel_cmd, peak_accel = [], 0.0, 0.0, 0.0
    previous_cmd = sim.controller.qdot_cmd.copy()
    previous = sim.data.qvel[0:6].copy()
    report = None
    while report is None:
        report = sim.step()
        manipulability.append(sim.controller.manipulability)
        qvel = sim.data.qvel[0:6]
        peak_speed = max(peak_speed, float(np.max(np.abs(qvel) / vmax)))
        accel_cmd = np.abs(sim.controller.qdot_cmd - previous_cmd) / sim.control_dt / JOINT_ACCEL_LIMIT
        peak_accel_cmd = max(peak_accel_cmd, float(accel_cmd.max()))
        peak_accel = max(
            peak_accel, float(np.max(np.abs(qvel - previous) / sim.control_dt / JOINT_ACCEL_LIMIT))
        )
        previous_cmd = sim.controller.qdot_cmd.copy()
        previous = qvel.copy()
    assert report.exit is ExitCondition.TIMEOUT  # the goal is out of reach; no inertial breach
    assert "limited: singularity (" in report.detail
    assert sim.state().limited == "singularity"
    assert report.peak_force < 12.0
    assert min(manipulability) < 0.1 * MANIPULABILITY_THRESHOLD  # it did reach the singular stretch
    assert peak_speed <= 1.02  # joint speeds stayed within the datasheet limits
    assert peak_accel_cmd <= 1.0 + 1e-9  # commands decelerate within the drives' limits
    assert peak_accel < 3.0  # and the servos follow them without jumps
    assert np.all(np.isfinite(sim.data.qpos))


def test_joint_speed_limits_scale_the_whole_motion() -> None:
    sim = Simulation("free_space")
    vmax = sim.layout.joint_speed_limit
    # A 3 rad turn in 50 ms with the stiff preset asks for ~12 rad/s at the wrist.
    sim.start(Ptwl(PtwlParams(rotation=[0, 0, 3.0], duration=0.05, preset="stiff", watchdog=5.0)))
    scales, peak_cmd = [], 0.0
    for _ in range(400):
        sim.step()
        scales.append(sim.controller.speed_scale)
        peak_cmd = max(peak_cmd, float(np.max(np.abs(sim.controller.qdot_cmd) / vmax)))
    assert min(scales) < 0.8  # the limit was active
    assert peak_cmd <= 1.0 + 1e-9
    report = sim.run_behavior(Ptwl(PtwlParams(translation=[0.01, 0, 0])))  # preempts the fast turn
    assert "speed" not in report.detail  # a gentle move is not limited
    fast = sim.run_behavior(Ptwl(PtwlParams(rotation=[0, 0, -3.0], duration=0.05, preset="stiff")))
    assert "speed" in fast.detail


def test_same_seed_same_trajectory_and_seeds_move_the_fixture() -> None:
    def run(seed: int) -> tuple[np.ndarray, np.ndarray]:
        sim = Simulation("surface", seed=seed)
        sim.run_behavior(Ptwl(PtwlParams(translation=[0.01, 0.0, 0.05], duration=2.0, force_threshold=10)))
        return sim.data.qpos.copy(), sim.model.body("plate_body").pos.copy()

    q_a, plate_a = run(7)
    q_b, plate_b = run(7)
    _, plate_c = run(8)
    np.testing.assert_array_equal(q_a, q_b)
    np.testing.assert_array_equal(plate_a, plate_b)
    assert not np.array_equal(plate_a, plate_c)
    assert np.all(np.abs(plate_c[0:2] - [0.38, 0.0]) <= 0.003)


def test_nan_in_the_physics_ends_the_behavior_fault_and_resets_safely() -> None:
    sim = Simulation("free_space")
    sim.start(Ptwl(PtwlParams(translation=[0.05, 0, 0], duration=2.0)))
    sim.run(0.5)
    sim.data.qvel[2] = math.nan
    report = None
    for _ in range(20):
        report = report or sim.step()
    assert report is not None and report.exit is ExitCondition.FAULT
    assert sim.fault_count == 1 and sim.last_fault
    assert np.allclose(sim.data.qpos[0:6], sim.scene.home_qpos, atol=1e-3)  # back home
    assert sim.run_behavior(Ptwl(PtwlParams(translation=[0.01, 0, 0]))).exit is ExitCondition.GOAL_REACHED


def test_500_hz_control_keeps_the_time_constant() -> None:
    sim = Simulation("free_space", gains=TEST_GAINS, control_hz=500.0)
    assert sim.n_substeps == 2
    t, error = step_response(sim, 1, 0.02, seconds=1.5)
    assert fit_time_constant(t, error) == pytest.approx(0.25, rel=0.05)


@pytest.mark.parametrize("hz", [250.0, 600.0, 1500.0])
def test_control_rate_must_divide_the_physics_rate(hz: float) -> None:
    with pytest.raises(RobotSimError, match="control_hz"):
        Simulation("free_space", control_hz=hz)


@pytest.mark.parametrize(
    ("move", "limits"),
    [
        # The two: a turn the wrist cannot make, and a lift past reach that also runs
        # joint 5 into its end (the report named only the singularity).
        ({"rotation": [3.1, 0, 0]}, ["joint_limit"]),
        ({"translation": [0, 0, 0.6], "frame": "base"}, ["singularity", "joint_limit"]),
    ],
)
def test_a_port_held_back_says_how_far_from_its_goal_and_every_limit(
    move: dict[str, Any], limits: list[str]
) -> None:
    sim = Simulation("free_space")
    ptwl = Ptwl(PtwlParams(duration=5.0, **move))
    report = sim.run_behavior(ptwl)
    assert report.exit is ExitCondition.TIMEOUT
    said = re.fullmatch(r"port ([\d.]+) mm and ([\d.]+) deg from its goal; limited: (.*)", report.detail)
    assert said is not None, report.detail
    distance_mm = 1000.0 * float(np.linalg.norm(ptwl.p_world_goal - sim.controller.p_world_port))
    assert float(said[1]) == pytest.approx(distance_mm, abs=0.05) and distance_mm > 100.0
    assert re.findall(r"(\w+) \(\d+\.\d\d s", said[3]) == limits  # longest first
    assert "joint 5 at its upper end, +120 deg" in said[3]
    upper_rad = sim.layout.joint_range[4, 1]
    assert upper_rad - 0.05 < sim.data.qpos[4] < upper_rad + 0.001  # at its end (the servo: +0.6 mrad)


def test_a_goal_reached_says_nothing_held_it_back() -> None:
    report = Simulation("free_space").run_behavior(Ptwl(PtwlParams(translation=[0.05, 0, 0], duration=2.0)))
    assert report.exit is ExitCondition.GOAL_REACHED and report.detail == ""
