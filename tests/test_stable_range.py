"""The accepted stiffness/damping range: stable in stiff contact, first-order in free space."""

import numpy as np
import pytest
from pydantic import ValidationError

from robot_sim.behaviors import ExitCondition, Ptwl
from robot_sim.gains import Gains
from robot_sim.limits import DAMPING_MIN, MIN_TIME_CONSTANT_S
from robot_sim.params import GainsSpec, PtwlParams
from robot_sim.sim import Simulation
from tests.helpers import step_response
from tests.test_contact import contact_force_world
from tests.test_ptwl import GAP_TO_PLATE

PLATE_TOP_Z, TIP_RADIUS = 0.220, 0.008


@pytest.mark.parametrize("stiffness", [2000.0, 4000.0, 8000.0, 16000.0])
def test_damping_200_settles_on_the_rigid_plate(stiffness: float) -> None:
    sim = Simulation("surface")
    ctl = sim.controller
    ctl.p_world_attractor[2] = PLATE_TOP_Z + TIP_RADIUS + 0.001
    sim.run(2.5)  # down to just above the plate with the default gains
    ctl.set_gains(Gains.of([stiffness] * 3 + [100] * 3, [DAMPING_MIN[0]] * 3 + [50] * 3))
    ctl.p_world_attractor[2] = PLATE_TOP_Z + TIP_RADIUS - 15.0 / stiffness
    sim.run(1.5)
    forces = [ctl.w_world_env_on_port[2] for _ in range(1000) if sim.step() is None]
    assert np.std(forces) < 0.5
    assert np.mean(forces) == pytest.approx(15.0, rel=0.08)


def test_without_the_f_t_filter_damping_200_limit_cycles() -> None:
    """Control for the test above: the low-pass is what makes B = 200 stable."""
    sim = Simulation("surface", ft_cutoff_hz=None)
    ctl = sim.controller
    ctl.p_world_attractor[2] = PLATE_TOP_Z + TIP_RADIUS + 0.001
    sim.run(2.5)
    ctl.set_gains(Gains.of([4000.0] * 3 + [100] * 3, [200.0] * 3 + [50] * 3))
    ctl.p_world_attractor[2] = PLATE_TOP_Z + TIP_RADIUS - 15.0 / 4000.0
    sim.run(1.5)
    forces = [ctl.w_world_env_on_port[2] for _ in range(1000) if sim.step() is None]
    assert np.std(forces) > 5.0


def test_thresholds_are_checked_on_the_raw_signal() -> None:
    # A 0.5 Hz filter lags a 20 N/s force ramp by ~6 N; the breach must not wait for it. Judged
    # by MuJoCo's own contact force at the breach, not by the controller's reading.
    sim = Simulation("surface", ft_cutoff_hz=0.5)
    distance = GAP_TO_PLATE + 0.03
    sim.start(Ptwl(PtwlParams(translation=[0, 0, distance], duration=distance / 0.01, force_threshold=15.0)))
    report = None
    while report is None:
        report = sim.step()
    assert report.exit is ExitCondition.WRENCH_BREACH
    # Raw check: 16.7 N (the contact is one physics step newer than the sensor reading, on a
    # rising impact). A breach judged on the 0.5 Hz signal would come at ~36 N.
    assert contact_force_world(sim)[2] < 20.0


def test_the_api_accepts_damping_200_and_says_why_it_refuses_less() -> None:
    GainsSpec(stiffness=[600, 600, 600, 100, 100, 100], damping=[200, 200, 200, 20, 20, 20])
    with pytest.raises(ValidationError, match=r"damping\[0\] \(x\) must be in \[200, 50000\] N s/m"):
        GainsSpec(stiffness=[500, 500, 500, 100, 100, 100], damping=[150, 200, 200, 50, 50, 50])
    with pytest.raises(ValidationError, match=r"\(z\) must be >= 0.3 s .*first-order"):
        GainsSpec(stiffness=[600, 600, 16000, 100, 100, 100], damping=[200, 200, 200, 50, 50, 50])
    with pytest.raises(ValidationError, match=r"\(rz\) must be >= 0.2 s"):
        GainsSpec(stiffness=[600, 600, 600, 100, 100, 1000], damping=[200, 200, 200, 50, 50, 50])


def first_order_figures(axis: int, size: float) -> tuple[float, float]:
    """(overshoot as a fraction of the step, 63 % time / tau) at the fastest accepted B/K."""
    tau = MIN_TIME_CONSTANT_S[axis]
    k = [1000.0 / MIN_TIME_CONSTANT_S[0]] * 3 + [50.0 / MIN_TIME_CONSTANT_S[3]] * 3
    sim = Simulation("free_space", gains=Gains.of(k, [1000.0] * 3 + [50.0] * 3))
    t, error = step_response(sim, axis, size, seconds=6 * tau)
    t63 = t[np.argmax(error <= np.exp(-1.0) * abs(size))] + sim.control_dt  # from the step
    return float(-error.min() / abs(size)), float(t63 / tau)


@pytest.mark.parametrize(
    ("axis", "size"), [(0, 0.1), (0, -0.1), (1, 0.1), (2, 0.1), (2, -0.1), (3, 0.5), (4, -0.5), (5, 0.5)]
)
def test_steps_are_first_order_at_the_fastest_accepted_gains(axis: int, size: float) -> None:
    overshoot, t63_over_tau = first_order_figures(axis, size)
    assert overshoot < 0.05
    assert t63_over_tau == pytest.approx(1.0, abs=0.10)
