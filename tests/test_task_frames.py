"""Task frames on the robot: commands in a frame's axes move, relieve, dither and comply along
those axes; the scenes' own frames sit where the seed put their fixtures."""

import math

import mujoco
import numpy as np
import pytest

from robot_sim.behaviors import Dither, ExitCondition, Ptwl, Rwe
from robot_sim.errors import ConfigError, UnknownNameError
from robot_sim.params import DitherParams, PtwlParams, RweParams
from robot_sim.sim import Simulation
from robot_sim.task_frames import FrameInUseError, TaskFrame, load_scene_frames, unit_quaternion
from tests.helpers import fit_time_constant
from tests.test_ptwl import GAP_TO_PLATE

TILT_RAD = math.radians(30.0)
# 30 degrees about base x: the frame's z leans toward base -y.
TILTED_WXYZ = unit_quaternion([math.cos(TILT_RAD / 2), math.sin(TILT_RAD / 2), 0.0, 0.0])


def tilted(name: str = "tilted", wxyz: "tuple[float, ...]" = TILTED_WXYZ) -> TaskFrame:
    return TaskFrame(name, (0.4, 0.0, 0.3), unit_quaternion(wxyz), "operator", "typed pose")


def R_of(wxyz: "tuple[float, ...]") -> np.ndarray:
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, np.asarray(wxyz, dtype=float))
    return R.reshape(3, 3)


def test_a_ptwl_in_a_task_frame_moves_along_its_axes() -> None:
    sim = Simulation("free_space")
    sim.frames.add(tilted())
    before = sim.controller.p_world_port.copy()
    move = PtwlParams(translation=[0.0, 0.0, 0.03], frame="tilted", duration=1.5)
    assert sim.run_behavior(Ptwl(move)).exit is ExitCondition.GOAL_REACHED
    moved = sim.controller.p_world_port - before
    expected = R_of(TILTED_WXYZ) @ [0.0, 0.0, 0.03]  # (0, -15, 26) mm
    np.testing.assert_allclose(moved, expected, atol=0.002)
    assert moved[1] < -0.012  # not base z: 30 degrees off it, toward -y


def test_gains_in_a_task_frame_are_diagonal_in_its_axes() -> None:
    """Stiff along the frame's z, soft across: a step along the frame's y decays with B/K of y,
    and stays along it (in base axes the same diagonal would mix y and z)."""
    sim = Simulation("free_space")
    sim.frames.add(tilted())
    stiffness = [1000.0, 2500.0, 3000.0, 100.0, 100.0, 100.0]  # tau = B/K: 1.0, 0.4, 0.33 s
    damping = [1000.0, 1000.0, 1000.0, 50.0, 50.0, 50.0]
    hold = PtwlParams(duration=0.1, stiffness=stiffness, damping=damping, gains_frame="tilted")
    assert sim.run_behavior(Ptwl(hold)).exit is ExitCondition.GOAL_REACHED
    ctl = sim.controller
    np.testing.assert_allclose(ctl.gains_rotation(), R_of(TILTED_WXYZ), atol=1e-12)
    direction = R_of(TILTED_WXYZ)[:, 1]
    ctl.p_world_attractor[:] = ctl.p_world_port + 0.01 * direction
    times, along, across = [], [], []
    for _ in range(2500):
        sim.step()
        stretch = ctl.p_world_attractor - ctl.p_world_port
        times.append(sim.time)
        along.append(float(stretch @ direction))
        across.append(float(np.linalg.norm(stretch - (stretch @ direction) * direction)))
    assert fit_time_constant(np.array(times) - times[0], np.array(along)) == pytest.approx(0.4, rel=0.05)
    assert max(across) < 0.05 * 0.01


def test_rwe_in_a_task_frame_relieves_its_axes() -> None:
    """A 10 N press on the plate: RWE on x, y of a frame whose x is base z relieves it; the same
    axes in base keep it (the press is along base z)."""
    sideways = unit_quaternion([math.cos(math.pi / 4), 0.0, math.sin(math.pi / 4), 0.0])  # x -> base -z
    outcomes = {}
    for frame in ("base", "sideways"):
        sim = Simulation("surface")
        sim.frames.add(tilted("sideways", sideways))
        press = PtwlParams(translation=[0.0, 0.0, GAP_TO_PLATE + 0.03], duration=4.0, force_threshold=10.0)
        assert sim.run_behavior(Ptwl(press)).exit is ExitCondition.WRENCH_BREACH
        sim.run(0.3)
        relieve = RweParams(axes=["x", "y"], frame=frame, duration=1.0)
        report = sim.run_behavior(Rwe(relieve))
        outcomes[frame] = (report.exit, abs(report.final_wrench[2]))
    assert outcomes["sideways"][0] is ExitCondition.COMPLETED and outcomes["sideways"][1] < 1.0
    assert outcomes["base"][1] > 8.0  # base x, y leave the press along base z alone


def test_dither_axis_in_a_task_frame() -> None:
    sim = Simulation("free_space")
    sim.frames.add(tilted())
    before = sim.controller.p_world_port.copy()
    dither = DitherParams(
        mode="translational", amplitude=0.002, axis=[0.0, 0.0, 1.0], frame="tilted", travel=0.02, duration=2.0
    )
    behavior = Dither(dither)
    assert sim.run_behavior(behavior).exit is ExitCondition.GOAL_REACHED
    np.testing.assert_allclose(behavior.axis_world, R_of(TILTED_WXYZ)[:, 2], atol=1e-12)
    moved = sim.controller.p_world_port - before
    assert float(moved @ R_of(TILTED_WXYZ)[:, 2]) >= 0.019


def test_an_unknown_frame_is_named_with_the_valid_ones() -> None:
    sim = Simulation("sleeve_on_peg")
    with pytest.raises(UnknownNameError, match="unknown task frame 'nope'; valid: base, peg_axis, tool"):
        sim.frames.get("nope")
    params = PtwlParams(frame="nope", gains_frame="peg_axis")
    assert sim.frames.unknown_in(params) == {"frame": "nope"}
    assert "its task frame is gone (frame 'nope')" in str(sim.frames.missing_reason(params))


def test_scene_frames_sit_on_the_seeded_fixture() -> None:
    nominal, seeded = Simulation("sleeve_on_peg"), Simulation("sleeve_on_peg", seed=5)
    for sim in (nominal, seeded):
        peg = sim.frames.get("peg_axis")
        site = sim.data.site_xpos[sim.model.site("peg_top").id]
        np.testing.assert_allclose(peg.position, site, atol=1e-12)
        assert peg.source == "scene" and peg.defined_by == "site peg_top"
    shift = np.subtract(seeded.frames.get("peg_axis").position, nominal.frames.get("peg_axis").position)
    assert np.linalg.norm(shift) > 1e-4  # the seed moved the peg, and its frame with it
    door = Simulation("door").frames.get("door_hinge")
    np.testing.assert_allclose(R_of(door.quaternion)[:, 2], [0.0, -1.0, 0.0], atol=1e-9)  # the hinge's axis


def test_frames_cannot_be_replaced_or_taken_while_named() -> None:
    sim = Simulation("surface")
    sim.frames.add(tilted())
    with pytest.raises(FrameInUseError, match="exists"):
        sim.frames.add(tilted())
    with pytest.raises(FrameInUseError, match="built-in"):
        sim.frames.add(tilted("tool"))
    with pytest.raises(FrameInUseError, match="scene's own"):
        sim.frames.remove("plate_normal", [])
    with pytest.raises(FrameInUseError, match=r"commands \[7\]"):
        sim.frames.remove("tilted", [7])
    assert sim.frames.remove("tilted", []).name == "tilted"
    sim.frames.add(tilted())
    sim.reset("surface")
    assert [f.name for f in sim.frames.all()] == ["plate_normal"]  # a reset drops the operator's


def test_a_bad_frames_file_names_the_key(tmp_path: "pytest.TempPathFactory") -> None:
    path = tmp_path / "frames.toml"  # type: ignore[operator]
    path.write_text('[surface.up]\nsite = "plate_top"\njoint = "x"\n')
    with pytest.raises(ConfigError, match=r"\[surface.up\] give exactly one of site or joint"):
        load_scene_frames(path)
    path.write_text('[surface.base]\nsite = "plate_top"\n')
    with pytest.raises(ConfigError, match="built-in"):
        load_scene_frames(path)


def test_a_scene_frames_offset_is_along_its_own_turned_axes() -> None:
    """`offset` moves the origin along the frame's axes after `turn`, not along the site's or the
    base's: a quarter turn about z makes an x offset point along the site's y."""
    from robot_sim.pose_math import rotation_matrix
    from robot_sim.task_frames import SceneFrameSpec

    sim = Simulation("free_space")
    mujoco.mj_forward(sim.model, sim.data)
    plain = SceneFrameSpec(site="goal").resolve("plain", sim.model, sim.data)
    turned = SceneFrameSpec(site="goal", turn=[0.0, 0.0, math.pi / 2], offset=[0.1, 0.0, 0.0])
    frame = turned.resolve("turned", sim.model, sim.data)
    R_world_site = rotation_matrix(np.asarray(plain.quaternion))
    expected = np.asarray(plain.position) + R_world_site @ np.array([0.0, 0.1, 0.0])
    np.testing.assert_allclose(frame.position, expected, atol=1e-12)
    R_world_frame = rotation_matrix(np.asarray(frame.quaternion))
    np.testing.assert_allclose(R_world_frame[:, 0], R_world_site[:, 1], atol=1e-12)  # x turned onto y
    unturned = SceneFrameSpec(site="goal", offset=[0.1, 0.0, 0.0]).resolve("o", sim.model, sim.data)
    np.testing.assert_allclose(unturned.quaternion, plain.quaternion, atol=1e-12)  # an offset never turns
