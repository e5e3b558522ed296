"""A gripper's grasp as MuJoCo models it: a weld between the tool and what it holds.

Closing the jaws (`actuate`) catches what has its grasp point between them and pulls it to
the grasp the jaws make: a part a few millimetres off is yanked into place, the paper's
closing impact (2.3.3). A task that begins at the grasp (`held_from_start`) instead welds what
is held as it is, so nothing jerks.
"""

import math
from collections.abc import Callable
from dataclasses import dataclass

import mujoco
import numpy as np

from robot_sim.errors import RobotSimError
from robot_sim.limits import GRIPPER_CLOSE_S

RELPOSE = slice(3, 10)  # a weld's eq_data: anchor (3), relative pose (pos 3, quat 4), torquescale


@dataclass(frozen=True)
class GripperSpec:
    """A scene's gripper: the weld that is its grasp, and what it can catch."""

    weld: str  # equality: body1 the tool, body2 what is held
    grasp_site: str  # on body2: the point and axes the port must be at to catch it
    capture_m: float = 0.006  # the jaws catch it within this of the port
    capture_rad: float = 0.2  # and with its axis within this of the tool's
    # The part is round about its grasp axis (a knob): the jaws close on it at whatever turn it
    # has about that axis. Otherwise they turn it to theirs, which twists a part that is held
    # (a tool locked in its bay: 72 N from a 0.4 rad misturn).
    round_about_axis: bool = False
    # The grasp is the task's start and the jaws never close on the part (a door's knob, a
    # sled's handle): its weld's time constant is how stiffly it is held, not a closing.
    held_from_start: bool = False


# The paper's pneumatic gripper (2.3.3, Table 1: a 51.8 N mean peak in retrieval, "largely due to
# the closing impact"): the closing time constant at which our retrieval's mean peak over seeds
# 0-99 comes to the paper's (docs/robot.md). The scenes' own, 10 ms, closes gently (~20 N).
PNEUMATIC_CLOSE_S = 0.0055


class GripperCloseError(RobotSimError, ValueError):
    """A closing time constant the scene cannot take (a ValueError: request models report it)."""


def takes_close_time(gripper: "GripperSpec | None") -> bool:
    """A gripper whose jaws close on a part: its closing time constant is the scene's to set."""
    return gripper is not None and not gripper.held_from_start


def check_close_time(scene: str, gripper: "GripperSpec | None", close_s: float | None) -> None:
    """The one check of a scene's `gripper_close_s`: a number in range, on a scene whose gripper
    closes on a part (the tool bay's)."""
    if close_s is None:
        return
    low, high = GRIPPER_CLOSE_S
    if not low <= close_s <= high:  # NaN fails both
        raise GripperCloseError(f"gripper_close_s must be in [{low}, {high}] s, got {close_s}")
    if gripper is None:
        raise GripperCloseError(f"gripper_close_s: the {scene} scene's tool has no gripper")
    if not takes_close_time(gripper):
        raise GripperCloseError(
            f"gripper_close_s: the {scene} scene's gripper holds its part from the start, never closing on it"
        )


def close_time(model: mujoco.MjModel, gripper: GripperSpec) -> float:
    """The jaws' closing time constant [s] in `model`."""
    return float(model.eq_solref[model.equality(gripper.weld).id, 0])


def set_close_time(model: mujoco.MjModel, gripper: GripperSpec, close_s: float) -> None:
    """Close the jaws with time constant `close_s` [s]: the grasp weld's solref, so a part a few
    millimetres off is pulled in over ~3 time constants, the faster the harder (from 10 to
    5.5 ms the retrieval's closing peak grows 2.4-2.8x)."""
    model.eq_solref[model.equality(gripper.weld).id, 0] = close_s


def actuate(
    model: mujoco.MjModel, data: mujoco.MjData, spec: GripperSpec, port_site: int, action: str
) -> str:
    """Close or open the jaws now; says what they hold."""
    weld = model.equality(spec.weld).id
    held = model.body(model.eq_obj2id[weld]).name
    if action == "open":
        was = bool(data.eq_active[weld])
        data.eq_active[weld] = 0
        return f"released {held}" if was else "opened (holding nothing)"
    if data.eq_active[weld]:
        return f"already holding {held}"
    site = model.site(spec.grasp_site).id
    off_m = float(np.linalg.norm(data.site_xpos[site] - data.site_xpos[port_site]))
    z_site = data.site_xmat[site].reshape(3, 3)[:, 2]
    z_port = data.site_xmat[port_site].reshape(3, 3)[:, 2]
    tilt_rad = math.acos(float(np.clip(z_site @ z_port, -1.0, 1.0)))
    if off_m > spec.capture_m or tilt_rad > spec.capture_rad:
        off = f"{1000 * off_m:.1f} mm, {math.degrees(tilt_rad):.0f} deg"
        return f"closed on nothing ({held}'s grasp point {off} off)"
    turn_rad = _turn_about_axis(data, site, port_site) if spec.round_about_axis else 0.0
    hold(model, data, weld, jaws_relpose(model, spec, port_site, turn_rad))
    return f"holding {held} (caught {1000 * off_m:.1f} mm off)"


def _turn_about_axis(data: mujoco.MjData, site: int, port_site: int) -> float:
    """[rad] how far the grasp site is turned about the port's z from the port's own axes: its
    x axis's angle in the port's x-y plane (the capture keeps the tilt under 0.2 rad)."""
    x_site = data.site_xmat[site].reshape(3, 3)[:, 0]
    r_port = data.site_xmat[port_site].reshape(3, 3)
    return math.atan2(float(r_port[:, 1] @ x_site), float(r_port[:, 0] @ x_site))


def jaws_relpose(
    model: mujoco.MjModel, spec: GripperSpec, port_site: int, turn_rad: float = 0.0
) -> np.ndarray:
    """(7,) the pose the jaws hold a part in, its body in the tool's frame: the grasp site on the
    port, turned `turn_rad` about the port's z. (tool <- port) (turn) (grasp site <- part)."""
    site = model.site(spec.grasp_site).id
    site_inv_pos, site_inv_quat = np.zeros(3), np.zeros(4)
    mujoco.mju_negPose(site_inv_pos, site_inv_quat, model.site_pos[site], model.site_quat[site])
    turn = np.zeros(4)
    mujoco.mju_axisAngle2Quat(turn, np.array([0.0, 0.0, 1.0]), turn_rad)
    port_turned = np.zeros(4)
    mujoco.mju_mulQuat(port_turned, model.site_quat[port_site], turn)
    pos, quat = np.zeros(3), np.zeros(4)
    mujoco.mju_mulPose(pos, quat, model.site_pos[port_site], port_turned, site_inv_pos, site_inv_quat)
    return np.concatenate([pos, quat])


def hold(model: mujoco.MjModel, data: mujoco.MjData | None, weld: int, relpose: np.ndarray) -> None:
    """Switch `weld` on with `relpose` (body2 in body1's frame): in `data`, or from the start
    (the model's initial state) when `data` is None."""
    model.eq_data[weld, RELPOSE] = relpose
    if data is None:
        model.eq_active0[weld] = 1
    else:
        data.eq_active[weld] = 1


def as_it_is(data: mujoco.MjData, body1: int, body2: int) -> np.ndarray:
    """(7,) body2's pose in body1's frame now."""
    q1_inv, pos, quat = np.zeros(4), np.zeros(3), np.zeros(4)
    mujoco.mju_negQuat(q1_inv, data.xquat[body1])
    mujoco.mju_rotVecQuat(pos, data.xpos[body2] - data.xpos[body1], q1_inv)
    mujoco.mju_mulQuat(quat, q1_inv, data.xquat[body2])
    return np.concatenate([pos, quat])


def held_from_start(weld_name: str) -> Callable[[mujoco.MjModel], Callable[[mujoco.MjData], None]]:
    """A scene mechanism: the gripper holds `weld_name`'s body from the first control tick on
    (a task that begins at the grasp)."""

    def bind(model: mujoco.MjModel) -> Callable[[mujoco.MjData], None]:
        weld = model.equality(weld_name).id
        started = False  # once: a gripper command may open it later

        def tick(data: mujoco.MjData) -> None:
            nonlocal started
            if not started:
                hold(model, data, weld, as_it_is(data, model.eq_obj1id[weld], model.eq_obj2id[weld]))
                started = True

        return tick

    return bind
