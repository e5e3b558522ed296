"""A gripper's grasp as MuJoCo models it: a weld between the tool and what it holds, switched on
with the two bodies' relative pose as they are at that moment (so closing never jerks)."""

from collections.abc import Callable

import mujoco
import numpy as np

RELPOSE = slice(3, 10)  # a weld's eq_data: anchor (3), relative pose (pos 3, quat 4), torquescale


def grasp(model: mujoco.MjModel, data: mujoco.MjData, weld: int) -> None:
    """Switch `weld` on, holding its body2 where it is now relative to its body1."""
    body1, body2 = model.eq_obj1id[weld], model.eq_obj2id[weld]
    q1_inv = np.zeros(4)
    mujoco.mju_negQuat(q1_inv, data.xquat[body1])
    pos, quat = np.zeros(3), np.zeros(4)
    mujoco.mju_rotVecQuat(pos, data.xpos[body2] - data.xpos[body1], q1_inv)
    mujoco.mju_mulQuat(quat, q1_inv, data.xquat[body2])
    model.eq_data[weld, RELPOSE] = np.concatenate([pos, quat])
    data.eq_active[weld] = 1


def release(data: mujoco.MjData, weld: int) -> None:
    data.eq_active[weld] = 0


def held_from_start(weld_name: str) -> Callable[[mujoco.MjModel], Callable[[mujoco.MjData], None]]:
    """A scene mechanism: the gripper holds `weld_name`'s body from the first control tick on
    (a task that begins at the grasp)."""

    def bind(model: mujoco.MjModel) -> Callable[[mujoco.MjData], None]:
        weld = model.equality(weld_name).id

        def tick(data: mujoco.MjData) -> None:
            if not data.eq_active[weld]:
                grasp(model, data, weld)

        return tick

    return bind
