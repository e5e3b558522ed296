"""Dither: each mode makes its specified motion and advances (push) or retreats (pull); every
preset is tried in free space and in a jam."""

import math

import numpy as np
import pytest

from robot_sim.behaviors import Dither, ExitCondition, Ptwl, Rwe
from robot_sim.behaviors.dither import perpendicular_basis
from robot_sim.params import DitherParams, PtwlParams, RweParams
from robot_sim.policies.sleeve_on_peg import INSERT
from robot_sim.pose_math import rotvec_from_to
from robot_sim.presets import default_presets
from robot_sim.scenes import sleeve_insertion_depth
from robot_sim.sim import Simulation


def circle_fit(t: np.ndarray, xy: np.ndarray) -> tuple[float, float]:
    """(radius, frequency [Hz]) of a point circling the origin: mean radius, phase-rate fit."""
    radius = float(np.mean(np.hypot(xy[:, 0], xy[:, 1])))
    phase = np.unwrap(np.arctan2(xy[:, 1], xy[:, 0]))
    return radius, float(np.polyfit(t, phase, 1)[0] / (2 * math.pi))


def free_space_dither(preset: str) -> tuple[Simulation, DitherParams, Dither]:
    """A free-space simulation and a not yet started Dither of `preset`."""
    params = DitherParams(preset=preset)
    return Simulation("free_space"), params, Dither(params)


@pytest.mark.parametrize("preset", ["translational_push", "translational_pull"])
def test_translational_preset_circles_and_travels(preset: str) -> None:
    sim, params, behavior = free_space_dither(preset)
    ctl = sim.controller
    p0 = ctl.p_world_port.copy()
    sim.start(behavior)
    e1, e2 = perpendicular_basis(behavior.axis_world)
    sign = 1.0 if params.direction == "push" else -1.0
    t, att, port = [], [], []
    report = None
    while report is None:
        report = sim.step()
        if sim.time < 1.0 / params.frequency or sim.time > params.duration:
            continue  # skip the amplitude ramp-in and the settling after the travel
        centre = p0 + sign * behavior.axis_world * params.travel * min(1.0, sim.time / params.duration)
        a = ctl.p_world_attractor - centre
        b = ctl.p_world_port - centre
        t.append(sim.time)
        att.append([a @ e1, a @ e2])
        port.append([b @ e1, b @ e2])
    assert report.exit is ExitCondition.GOAL_REACHED
    radius, freq = circle_fit(np.array(t), np.array(att))
    assert radius == pytest.approx(params.amplitude, rel=0.05)
    assert freq == pytest.approx(params.frequency, rel=0.05)
    # The port follows through the admittance: same frequency, amplitude of a first-order lag.
    tau = ctl.gains.time_constants_s()[0]
    port_radius, port_freq = circle_fit(np.array(t), np.array(port))
    assert port_freq == pytest.approx(params.frequency, rel=0.05)
    lag_gain = 1.0 / math.hypot(1.0, 2 * math.pi * params.frequency * tau)
    assert port_radius == pytest.approx(params.amplitude * lag_gain, rel=0.10)
    advanced = sign * float((np.array(report.final_port.position) - p0) @ behavior.axis_world)
    assert params.travel - 0.001 <= advanced <= params.travel + 0.001


@pytest.mark.parametrize("preset", ["torsional_push", "torsional_pull"])
def test_torsional_preset_turns_about_its_axis_with_the_origin_on_it(preset: str) -> None:
    """Paper 2.2.3: "the attractor rotates about a specified axis while keeping its origin on it"."""
    sim, params, behavior = free_space_dither(preset)
    ctl = sim.controller
    p0 = ctl.p_world_attractor.copy()
    q0 = ctl.q_world_attractor.copy()
    sim.start(behavior)
    axis = behavior.axis_world
    t, angle, off_axis_turn, off_axis_origin = [], [], [], []
    report = None
    while report is None:
        report = sim.step()
        if sim.time < 1.0 / params.frequency or sim.time > params.duration:
            continue
        turn = rotvec_from_to(q0, ctl.q_world_attractor)
        t.append(sim.time - sim.control_dt)  # the attractor was set for the tick's start
        angle.append(float(turn @ axis))
        off_axis_turn.append(float(np.linalg.norm(turn - (turn @ axis) * axis)))
        rel = ctl.p_world_attractor - p0
        off_axis_origin.append(float(np.linalg.norm(rel - (rel @ axis) * axis)))
    assert report.exit is ExitCondition.GOAL_REACHED
    # Back and forth by +-amplitude about the axis, at the frequency, and nothing else.
    assert max(angle) == pytest.approx(params.amplitude, rel=0.02)
    assert min(angle) == pytest.approx(-params.amplitude, rel=0.02)
    fit = np.array(angle) - params.amplitude * np.sin(2 * math.pi * params.frequency * np.array(t))
    assert np.abs(fit).max() < 1e-6
    assert max(off_axis_turn) < 1e-9
    assert max(off_axis_origin) < 1e-9
    sign = 1.0 if params.direction == "push" else -1.0
    moved = sign * float((np.array(report.final_port.position) - p0) @ axis)
    assert params.travel - 0.0015 <= moved <= params.travel + 0.0015


@pytest.mark.parametrize("preset", sorted(default_presets().dither))
def test_no_preset_breaches_its_own_threshold_from_the_wiggle(preset: str) -> None:
    """A fully blocked wiggle builds K x amplitude; the preset's threshold must sit above it."""
    params = DitherParams(preset=preset)
    medium = default_presets().stiffness_preset(default_presets().default_stiffness)
    if params.mode == "torsional":
        assert medium.stiffness[5] * params.amplitude < params.torque_threshold
    else:
        assert medium.stiffness[0] * params.amplitude < params.force_threshold


def jammed_sleeve() -> Simulation:
    sim = Simulation("sleeve_on_peg")
    sim.run_behavior(Ptwl(PtwlParams(rotation=[0.052, 0, 0], duration=1.0)))
    jam = sim.run_behavior(Ptwl(INSERT))
    assert jam.exit is ExitCondition.WRENCH_BREACH
    sim.run_behavior(Rwe(RweParams()))
    return sim


@pytest.mark.parametrize("preset", sorted(default_presets().dither))
def test_every_preset_in_a_jam(preset: str) -> None:
    sim = jammed_sleeve()
    depth = sleeve_insertion_depth(sim)
    assert 0.0 < depth < 0.010
    params = DitherParams(preset=preset)
    report = sim.run_behavior(Dither(params))
    moved = sleeve_insertion_depth(sim) - depth
    assert report.exit is not ExitCondition.WRENCH_BREACH  # no self-breach, even jammed
    if params.direction == "pull":
        assert report.exit is ExitCondition.GOAL_REACHED  # backs out of the jam
        assert moved < -(params.travel - 0.0015)
    elif params.mode == "torsional":
        # The twist walks the sleeve in, 1.5 mm over its 11 s in a fit as stiff as the rigid one
        # (3 mm in the softer contact before): why the sleeve's machine backs out and re-aims.
        assert moved > 0.001
    else:
        assert report.exit is ExitCondition.TIMEOUT and abs(moved) < 0.003  # circles do not free it


def test_every_dither_preset_is_a_valid_request() -> None:
    presets = default_presets().dither
    assert set(presets) == {"torsional_push", "torsional_pull", "translational_push", "translational_pull"}
    for name in presets:
        assert DitherParams(preset=name).mode in ("torsional", "translational")


def test_explicit_fields_override_the_preset() -> None:
    """The preset supplies every field not given (each differs from the model's default here),
    the request's own fields win."""
    params = DitherParams(preset="translational_push", frequency=2.5, amplitude=0.001)
    assert params.frequency == 2.5 and params.amplitude == 0.001 and params.direction == "push"
    preset = default_presets().dither_preset("translational_push")
    given = {"frequency", "amplitude", "preset"}
    from_preset = {name: getattr(params, name) for name in preset if name not in given}
    assert from_preset == {name: value for name, value in preset.items() if name not in given}
    defaults = DitherParams()  # so the preset's fields are told from the model's defaults
    assert defaults.mode != params.mode == "translational" and defaults.travel != params.travel == 0.02


def test_a_push_ends_on_its_progress_before_its_travel() -> None:
    """`progress` ends a push `goal_reached` once the port has advanced that far (a jam that has
    given), while the attractor still heads for the whole travel: in free space a 5 mm progress
    of a 20 mm, 6 s push ends about a quarter of the way, not near the end (19 mm, at ~5.7 s)."""
    sim = Simulation("free_space")
    params = DitherParams(preset="torsional_push", progress=0.005)
    assert params.travel == 0.02 and params.duration == 6.0
    behavior = Dither(params)
    p0 = sim.controller.p_world_port.copy()
    report = sim.run_behavior(behavior)
    assert report.exit is ExitCondition.GOAL_REACHED
    advanced = float((np.array(report.final_port.position) - p0) @ behavior.axis_world)
    assert 0.004 - 1e-4 <= advanced <= 0.0045  # within the travel tolerance (1 mm) of 5 mm
    # The attractor ramps 20 mm over 6 s and the port lags it by tau = 0.5 s: 4 mm at ~1.7 s.
    assert 1.2 < report.duration < 2.4
    # Without it, the same push runs its whole travel.
    assert sim.run_behavior(Dither(DitherParams(preset="torsional_push"))).duration > 5.0


def test_progress_is_within_the_travel_and_a_preset_brings_none() -> None:
    assert DitherParams(travel=0.02).progress is None  # the travel ends it
    with pytest.raises(ValueError, match=r"progress \(0.03 m\) must be <= travel \(0.02 m\)"):
        DitherParams(travel=0.02, progress=0.03)
    with pytest.raises(ValueError, match=r"progress"):  # at the 1 mm tolerance it would end at once
        DitherParams(progress=0.001)
    # A preset with another travel: the request's travel ends it, shorter or longer (a preset that
    # carried its own progress refused the shorter and ended the longer at 20 mm).
    for travel in (0.01, 0.05):
        assert DitherParams(preset="torsional_push", travel=travel).progress is None
    assert "progress" not in default_presets().dither_preset("torsional_push")
