"""Dither: each mode makes its specified motion and advances (push) or retreats (pull)."""

import math

import mujoco
import numpy as np
import pytest

from robot_sim.behaviors.base import ExitCondition
from robot_sim.behaviors.dither import Dither, perpendicular_basis
from robot_sim.params import DitherParams
from robot_sim.presets import default_presets
from robot_sim.sim import Simulation


def rotvec_between(q_to: np.ndarray, q_from: np.ndarray) -> np.ndarray:
    """Base-axes rotation vector taking q_from to q_to."""
    q_from_inv = np.zeros(4)
    q_rel = np.zeros(4)
    mujoco.mju_negQuat(q_from_inv, q_from)
    mujoco.mju_mulQuat(q_rel, q_to, q_from_inv)
    out = np.zeros(3)
    mujoco.mju_quat2Vel(out, q_rel, 1.0)
    return out


def circle_fit(t: np.ndarray, xy: np.ndarray) -> tuple[float, float]:
    """(radius, frequency [Hz]) of a point circling the origin: mean radius, phase-rate fit."""
    radius = float(np.mean(np.hypot(xy[:, 0], xy[:, 1])))
    phase = np.unwrap(np.arctan2(xy[:, 1], xy[:, 0]))
    return radius, float(np.polyfit(t, phase, 1)[0] / (2 * math.pi))


@pytest.mark.parametrize(
    "preset", ["torsional_push", "torsional_pull", "translational_push", "translational_pull"]
)
def test_dither_preset_motion_and_travel(preset: str) -> None:
    sim = Simulation("free_space")
    ctl = sim.controller
    params = DitherParams(preset=preset)
    behavior = Dither(params)
    p0 = ctl.p_world_port.copy()
    q0 = ctl.q_world_port.copy()
    sim.start(behavior)
    e1, e2 = perpendicular_basis(behavior.axis_world)
    sign = 1.0 if params.direction == "push" else -1.0
    t, att, port = [], [], []
    report = None
    while report is None:
        report = sim.step()
        elapsed = sim.time  # the dither started at t = 0
        if sim.time < 1.0 / params.frequency or sim.time > params.duration:
            continue  # skip the amplitude ramp-in and the settling after the travel
        if params.mode == "translational":
            centre = p0 + sign * behavior.axis_world * params.travel * min(1.0, elapsed / params.duration)
            a = ctl.p_world_attractor - centre
            b = ctl.p_world_port - centre
        else:
            a = rotvec_between(ctl.q_world_attractor, q0)
            b = rotvec_between(ctl.q_world_port, q0)
        t.append(sim.time)
        att.append([a @ e1, a @ e2])
        port.append([b @ e1, b @ e2])
    assert report.exit is ExitCondition.GOAL_REACHED
    radius, freq = circle_fit(np.array(t), np.array(att))
    assert radius == pytest.approx(params.amplitude, rel=0.05)
    assert freq == pytest.approx(params.frequency, rel=0.05)
    # The port follows through the admittance: same frequency, amplitude of a first-order lag.
    axis = 0 if params.mode == "translational" else 3
    tau = ctl.gains.time_constants_s()[axis]
    port_radius, port_freq = circle_fit(np.array(t), np.array(port))
    assert port_freq == pytest.approx(params.frequency, rel=0.05)
    lag_gain = 1.0 / math.hypot(1.0, 2 * math.pi * params.frequency * tau)
    assert port_radius == pytest.approx(params.amplitude * lag_gain, rel=0.10)
    # Advance along the axis by the travel (to within the exit tolerance).
    advanced = sign * float((np.array(report.final_port.position) - p0) @ behavior.axis_world)
    assert params.travel - 0.001 <= advanced <= params.travel + 0.001


def test_every_dither_preset_is_a_valid_request() -> None:
    presets = default_presets().dither
    assert set(presets) == {"torsional_push", "torsional_pull", "translational_push", "translational_pull"}
    for name in presets:
        assert DitherParams(preset=name).mode in ("torsional", "translational")


def test_explicit_fields_override_the_preset() -> None:
    params = DitherParams(preset="translational_push", frequency=2.5, amplitude=0.001)
    assert params.frequency == 2.5 and params.amplitude == 0.001 and params.direction == "push"
