"""Free space: the port follows an attractor step as a first-order lag with time constant B/K."""

import numpy as np
import pytest

from robot_sim.sim import Simulation
from tests.helpers import TEST_GAINS, fit_time_constant, step_response

POSES = {
    "home": None,  # tool down in front of the base
    "twisted": (0.6, -0.2, 0.5, 0.5, 0.9, -0.4),  # wrist rolled, arm swung aside
}


@pytest.mark.parametrize("pose", list(POSES))
@pytest.mark.parametrize(("axis", "step"), [(0, 0.02), (2, -0.015), (3, 0.08), (5, -0.1)])
def test_step_is_first_order_with_time_constant_b_over_k(pose: str, axis: int, step: float) -> None:
    sim = Simulation("free_space", gains=TEST_GAINS, qpos=POSES[pose])
    expected = TEST_GAINS.time_constants_s()[axis]
    t, error = step_response(sim, axis, step, seconds=6 * expected)
    tau = fit_time_constant(t, error)
    assert tau == pytest.approx(expected, rel=0.05)
    # First order: no overshoot, and the 63% point sits at one time constant.
    assert error.min() >= -1e-4
    t63 = t[np.argmax(error <= np.exp(-1) * error[0])]
    assert t63 == pytest.approx(expected, rel=0.05)
    assert error[-1] < 0.01 * abs(step)


def test_other_axes_stay_put_during_a_step() -> None:
    sim = Simulation("free_space", gains=TEST_GAINS)
    p0 = sim.controller.p_world_port.copy()
    step_response(sim, 0, 0.02, seconds=1.5)
    drift = sim.controller.p_world_port - p0
    assert drift[0] == pytest.approx(0.02, abs=2e-4)
    assert abs(drift[1]) < 2e-4 and abs(drift[2]) < 5e-4
