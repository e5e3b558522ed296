"""The ground twin registers its fixture from the robot's contacts (issue 29 point 6; the
teleoperation paper's 2.5 Model Update). With the plate 1 mm lower than the twin's model, main's
twin restarted with its tool 1 mm inside its own plate, felt a spurious ~50 N and ended the slide
the robot went on with: 22.8 mm off at 1 s RTT, 34 mm at 2 s, worse than no twin (the delayed
picture)."""

import mujoco
import numpy as np
import pytest

from ptwl.experiments.twin.trial import contact_moves, robot_with_model_error, run_trial
from robot_sim.behaviors.ptwl import Ptwl
from robot_sim.behaviors.rwe import Rwe
from robot_sim.params import PtwlParams, RweParams
from robot_sim.sim import Simulation
from robot_sim.telemetry import state_fields
from web.twin import GroundTwin
from web.twin_inbox import TwinInbox
from web.twin_registration import INSIDE_M, MAX_SHIFT_M, WINDOW, FixtureRegistration
from web.twin_sim import TwinSim
from web.twin_trust import twin_readout


def test_a_plate_1_mm_low_is_found_at_the_first_contact_and_the_twin_beats_the_delayed_picture() -> None:
    seen: list[GroundTwin] = []
    nominal = run_trial(
        robot_with_model_error("surface", 3, (0.0, 0.0, -0.001)), 2.0, contact_moves(), 10.0, register=False
    )
    registered = run_trial(
        robot_with_model_error("surface", 3, (0.0, 0.0, -0.001)),
        2.0,
        contact_moves(),
        10.0,
        twin_scene_check=seen.append,
    )
    assert nominal.max_mm > 20.0 and nominal.max_mm > 0.8 * nominal.delayed_max_mm  # main's failure: 34 mm
    after = registered.after_contact_max_mm
    assert after is not None and after < 1.0  # 0.1 mm; the issue asks <= 3
    assert registered.max_mm < 1.5  # before the contact the twin cannot know: the 1 mm itself
    assert registered.max_mm < 0.1 * registered.delayed_max_mm
    [twin] = seen
    assert twin.registered is not None and twin.registered.body == "plate_body"
    dx, dy, dz = twin.registered.shift_m
    assert dz == pytest.approx(-0.001, abs=0.0002) and abs(dx) < 1e-4 and abs(dy) < 1e-4  # sideways: unseen
    assert twin.advanced_wall is not None
    _, readout = twin_readout(twin.advanced_wall, twin)
    assert "its plate_body moved 1.0 mm (+0.0, +0.0, -1.0) to fit the robot's contacts" in readout


def pressed(lift_m: float) -> Simulation:
    """The probe pressed onto the plate at ~10 N; with `lift_m`, relieved (RWE) and lifted that
    far off it."""
    sim = Simulation("surface")
    sim.run_behavior(Ptwl(PtwlParams(translation=[0.0, 0.0, 0.06], duration=2.0, force_threshold=10.0)))
    if lift_m:
        sim.run_behavior(Rwe(RweParams(duration=1.0)))
        sim.run_behavior(
            Ptwl(PtwlParams(translation=[0.0, 0.0, -lift_m], duration=1.0, position_tolerance=1e-4))
        )
    return sim


def tip_to_plate_m(sim: Simulation) -> float:
    model = sim.model
    plate, tip = model.geom("plate").id, model.geom("arm/tool/tool_tip").id
    return float(mujoco.mj_geomDistance(model, sim.data, plate, tip, 0.05, np.zeros(6)))


def test_a_contact_the_twin_lacks_moves_its_fixture_to_it_and_free_on_both_sides_says_nothing() -> None:
    twin = pressed(0.002)  # the twin's tool 2 mm over its plate
    registration = FixtureRegistration(twin)
    registration.observe(twin, force_n=0.5)  # the robot free too: nothing learnt
    assert registration.registered().samples == 0
    registration.observe(twin, force_n=12.0)  # the robot touching where the twin is 2 mm off
    shift = registration.registered().shift_m
    assert shift[2] == pytest.approx(0.002, abs=0.0002) and registration.registered().samples == 1
    assert abs(tip_to_plate_m(twin)) < 1e-4  # now the twin touches, as the robot does


def test_a_twin_inside_its_fixture_while_the_robot_is_free_moves_it_out_and_never_far() -> None:
    twin = pressed(0.0)  # the twin's tool pressed into its plate
    registration = FixtureRegistration(twin)
    inside = registration._closest(twin)
    assert inside is not None and inside[0] < 0.0  # the contact's own overlap
    registration.observe(twin, force_n=0.0)  # the robot free there: the plate is lower
    assert registration.registered().shift_m[2] == pytest.approx(inside[0], abs=2e-5)
    assert tip_to_plate_m(twin) >= -INSIDE_M  # and the twin is out of its own plate
    registration._restarts.extend([[(np.array([0.0, 0.0, 1.0]), 0.05, False)]] * 5)  # 50 mm: no small error
    registration._solve()
    assert float(np.linalg.norm(registration.registered().shift_m)) == pytest.approx(MAX_SHIFT_M)


def test_a_free_robot_bounds_the_fixture_and_a_touching_one_places_it() -> None:
    """Free where the twin overlaps 0.5 mm: the plate is at least 0.5 mm lower, not exactly; a
    touch 2 mm lower is the fit (a least-squares average of the two would put it 1.25 mm low)."""
    twin = pressed(0.002)
    registration = FixtureRegistration(twin)
    up = np.array([0.0, 0.0, 1.0])
    registration._restarts.extend([[(up, -0.0005, True)], [(up, -0.002, False)]])
    registration._solve()
    assert registration.registered().shift_m[2] == pytest.approx(-0.002, abs=1e-9)
    registration._restarts.clear()
    registration._restarts.extend([[(up, 0.001, False)], [(up, 0.0, False)], [(up, -0.0005, True)]])
    registration._solve()  # two touches, then a bound that both break: the bound, now, nearly wins
    assert registration.registered().shift_m[2] == pytest.approx(-0.0005, abs=1e-6)
    assert registration.registered().shift_m[2] < -0.0005 + 3e-7  # (0.0005 / 10^4 short of it)
    registration._restarts.clear()
    registration._restarts.extend([[(up, -0.0005, True)], [(up, 0.001, False)]])  # the touch breaks the bound
    registration._solve()
    assert registration.registered().shift_m[2] == pytest.approx(0.001, abs=1e-6)  # the latest outranks it


def test_a_reload_forgets_the_layout_and_a_remade_model_gets_the_shift_again() -> None:
    twin = pressed(0.002)
    registration = FixtureRegistration(twin)
    plate = twin.model.body("plate_body").id
    nominal = twin.model.body_pos[plate].copy()
    registration.observe(twin, force_n=12.0)  # the robot touching where the twin's tool is 2 mm up
    assert twin.model.body_pos[plate][2] == pytest.approx(nominal[2] + 0.002, abs=2e-4)
    twin.reset("surface")  # the twin's own fault reloads its scene: a model made anew, nominal
    assert twin.model.body_pos[plate][2] == pytest.approx(nominal[2])
    registration.observe(twin, force_n=0.0)  # the shift is put back before anything is measured
    assert twin.model.body_pos[plate][2] == pytest.approx(nominal[2] + 0.002, abs=2e-4)
    registration.forget(twin)  # the robot reloaded its scene: nothing of the old layout stays
    assert registration.registered().samples == 0 and registration.registered().moved_mm == 0.0
    assert twin.model.body_pos[plate][2] == pytest.approx(nominal[2])


def test_the_twin_hears_a_reload_once_and_forgets_its_fixture_then() -> None:
    inbox = TwinInbox()
    inbox.state_arrived({"sim_time": 5.0})
    assert not inbox.take().reloaded
    inbox.state_arrived({"sim_time": 0.02})  # sim time went back: the robot reloaded its scene
    inbox.state_arrived({"sim_time": 0.04})
    assert inbox.take().reloaded and not inbox.take().reloaded
    twin = TwinSim()
    twin.load("surface")
    assert twin.registration is not None and twin.sim is not None
    plate = twin.sim.model.body("plate_body").id
    nominal = twin.sim.model.body_pos[plate].copy()
    twin.registration._restarts.append([(np.array([0.0, 0.0, 1.0]), -0.001, False)])
    twin.registration._solve()
    twin.registration._place(twin.sim)
    twin.forget_registration()
    assert (
        np.array_equal(twin.sim.model.body_pos[plate], nominal)
        and twin.registration.registered().samples == 0
    )
    assert TwinSim(register=False).load("surface")  # the nominal twin: no registration at all


def test_the_fit_rests_on_the_last_20_restarts_only() -> None:
    """An old layout's evidence goes out of the window: 25 touches, the first 5 of another place."""
    registration = FixtureRegistration(Simulation("surface"))
    up = np.array([0.0, 0.0, 1.0])
    for d0 in [0.004] * 5 + [-0.001] * 20:
        registration._restarts.append([(up, d0, False)])
    registration._solve()
    assert registration.registered().samples == WINDOW == 20
    assert registration.registered().shift_m[2] == pytest.approx(-0.001, abs=1e-12)


def pressed_robot(shift_m: tuple[float, float, float]) -> Simulation:
    """A robot whose plate is `shift_m` off the model, its probe pressed onto it at ~10 N."""
    robot = robot_with_model_error("surface", None, shift_m)
    robot.run_behavior(Ptwl(PtwlParams(translation=[0.0, 0.0, 0.06], duration=2.0, force_threshold=10.0)))
    return robot


def heard(twin: GroundTwin, robot: Simulation, wall: float) -> None:
    """The console hears the robot's state at `wall` (no link delay) and the twin's thread runs
    (the calls below are seconds apart: each restarts the twin from the state)."""
    twin.on_state({**state_fields(robot, []), "sent_at": wall, "taken_at": wall}, wall)
    twin.advance(wall)


def test_the_console_shows_a_moved_fixture_and_forgets_it_when_the_scene_reloads() -> None:
    right = GroundTwin(uplink_s=lambda: 0.0)
    heard(right, pressed_robot((0.0, 0.0, 0.0)), 1_800_000_000.0)
    assert right.registered is None  # the model was right: its own contact's overlap is not shown
    twin = GroundTwin(uplink_s=lambda: 0.0)
    robot = pressed_robot((0.0, 0.0, -0.001))
    heard(twin, robot, 1_800_000_010.0)
    assert twin.registered is not None and twin.registered.moved_mm == pytest.approx(1.0, abs=0.2)
    robot.reset("surface")  # the robot reloads the same scene (its sim time starts again)
    robot.run(0.1)
    heard(twin, robot, 1_800_000_020.0)
    assert twin.registered is None  # the old layout's fit is gone with it


def test_a_restart_never_leaves_the_twin_inside_its_fixture_when_old_evidence_disagrees() -> None:
    """The window's older equations, from other places around a 16-sided sleeve, outvoted the
    newest: a twin restarted with its sleeve 0.9 mm into its peg and was thrown 15 mm. Each
    restart now adds the deepest pair while the fit leaves the twin inside."""
    twin = Simulation("sleeve_on_peg")
    twin.run_behavior(Ptwl(PtwlParams(translation=[0.0, 0.0, 0.032], duration=2.0, force_threshold=40.0)))
    registration = FixtureRegistration(twin)
    peg = twin.model.body("peg_base").id
    x = np.array([1.0, 0.0, 0.0])
    registration._restarts.extend([[(x, 0.0, False)]] * (WINDOW - 1))  # "the peg is where the model says"
    twin.model.body_pos[peg][0:2] += 0.0005  # and now the model's peg 0.7 mm into the sleeve's walls
    mujoco.mj_forward(twin.model, twin.data)
    registration._nominal = twin.model.body_pos[peg].copy()
    inside = registration._closest(twin)
    assert inside is not None and inside[0] < -0.0004
    registration.observe(twin, force_n=5.0)
    after = registration._closest(twin)
    assert after is not None and after[0] >= -INSIDE_M, after
    latest = registration._restarts[-1]
    assert len(latest) >= 2  # one pair was not enough: the next deepest was added, as a bound
    assert not latest[0][2] and all(bound for _, _, bound in latest[1:])


def held_at_a_jam(
    seed: int | None, peg_shift_m: float, travel_m: float, limit_n: float = 40.0
) -> tuple[Simulation, dict[str, object]]:
    """A robot whose sleeve is held at `limit_n` (an insertion `travel_m` down the tool axis that
    breached, the attractor left to hold the limit), and the state it sends, its peg at `seed`'s
    place and then `peg_shift_m` along x, where the twin's model has it at the nominal place."""
    robot = robot_with_model_error("sleeve_on_peg", seed, (peg_shift_m, 0.0, 0.0))
    insertion = PtwlParams(
        translation=[0.0, 0.0, travel_m], frame="tool", duration=3.0, force_threshold=limit_n
    )
    assert robot.run_behavior(Ptwl(insertion)).exit.value == "wrench_breach"
    robot.run(0.5)  # still, holding
    return robot, {**state_fields(robot, []), "sent_at": 0.0, "taken_at": 0.0}


@pytest.mark.parametrize("register", [False, True])
def test_a_twin_that_cannot_bear_the_robots_press_holds_where_the_robot_is_held(register: bool) -> None:
    """Idle and held still at its 40 N limit on a peg 1 mm beside the twin's, the robot stays;
    main's twin ran to the attractor set against that force (nothing in its model bore it) and
    slid 20-26 mm on. It now holds, pressing on nothing; a twin whose model bears the press
    keeps it (the attractor where the robot's is)."""
    robot, state = held_at_a_jam(5, 0.001, 0.05)  # jammed at the mouth
    twin = TwinSim(register)
    twin.load("sleeve_on_peg")
    twin.restart(state, None, [], 0.5, robot.frames)
    assert twin.sim is not None
    start = twin.sim.controller.p_world_port.copy()
    stretch_mm = 1000 * float(np.linalg.norm(twin.sim.controller.stretch_world()[0:3]))
    twin.run_to(twin.sim.time + 2.0, lambda t, p: None)
    assert 1000 * float(np.linalg.norm(twin.sim.controller.p_world_port - start)) < 0.5
    assert stretch_mm < 0.1  # it holds pressing on nothing
    robot, state = held_at_a_jam(None, 0.0, 0.07, 15.0)  # the model right: bottomed, its peg bears it
    twin = TwinSim(register)
    twin.load("sleeve_on_peg")
    twin.restart(state, None, [], 0.5, robot.frames)
    assert twin.sim is not None
    reported = np.asarray(state["attractor"]["position"])  # type: ignore[index]
    assert float(np.linalg.norm(twin.sim.controller.p_world_attractor - reported)) < 1e-9
    # and it starts where and when the robot was, not where its 50 ms probe left it
    assert twin.sim.time == state["sim_time"]
    joints = twin.sim.data.qpos[twin.sim.layout.qpos_adr]
    assert np.array_equal(joints, np.asarray(state["joint_positions"]))  # type: ignore[arg-type]


PEG_INSERTION = [
    (1.0, PtwlParams(translation=[0, 0, 0.05], frame="tool", duration=3.0, force_threshold=40.0))
]


@pytest.mark.parametrize(
    ("peg_shift_m", "register"),
    [((0.001, 0.0, 0.0), False), ((0.001, 0.0, 0.0), True), ((0.0005, 0.0, -0.002), True)],
)
def test_after_the_first_contact_the_twin_is_within_3_mm_with_the_peg_elsewhere(
    peg_shift_m: tuple[float, float, float], register: bool
) -> None:
    """Issue 29 point 6 on the tight fit, at 1 s RTT. The peg 1 mm aside: the robot's sleeve jams
    at the mouth and the twin's slid on, 26 mm off (now 0.02 mm: it holds where the robot is
    held, registering or not). The peg 2 mm low and 0.5 mm aside: the robot slides on and the
    twin restarted up to 0.9 mm inside its peg and was thrown, 15 mm off (now 0.6 mm)."""
    robot = robot_with_model_error("sleeve_on_peg", 5, peg_shift_m)
    result = run_trial(robot, 1.0, PEG_INSERTION, 8.0, register=register)
    after = result.after_contact_max_mm
    assert after is not None and after <= 3.0, after
    assert after < result.delayed_max_mm / 4
