"""Quaternion helpers on mujoco.mju_* (quaternions [w x y z], rotation vectors [rad])."""

import math

import mujoco
import numpy as np

from robot_sim.tick import angle_between, rotate_world  # noqa: F401 (compiled; one copy, shared with the tick)


def rotation_matrix(quat: np.ndarray) -> np.ndarray:
    """(3, 3) rotation matrix of a unit quaternion (allocates: not for the 1 kHz path)."""
    flat = np.zeros(9)
    mujoco.mju_quat2Mat(flat, np.asarray(quat, dtype=float))
    return flat.reshape(3, 3)


def turn6(R: np.ndarray, v6: np.ndarray) -> np.ndarray:
    """(6,) both 3-blocks of a twist, wrench or stretch (linear, angular) turned by R (3, 3)."""
    return np.concatenate([R @ v6[0:3], R @ v6[3:6]])


def rotvec_from_to(q_from: np.ndarray, q_to: np.ndarray) -> np.ndarray:
    """(3,) base-axes rotation vector r [rad] with q_to = exp(r) * q_from (allocates)."""
    q_inv = np.zeros(4)
    q_rel = np.zeros(4)
    mujoco.mju_negQuat(q_inv, np.asarray(q_from, dtype=float))
    mujoco.mju_mulQuat(q_rel, np.asarray(q_to, dtype=float), q_inv)
    out = np.zeros(3)
    mujoco.mju_quat2Vel(out, q_rel, 1.0)
    return out


def direction_and_norm(values: "list[float] | tuple[float, ...]") -> tuple[list[float], float]:
    """(values / |values|, |values|) for finite values of any size, without overflow or underflow:
    divided by the largest component first (the squares of 1e200 overflow to inf and those of
    1e-200 underflow to 0, so mju_normalize gave [0, ...] or silently a default). A zero vector
    gives (zeros, 0.0): the caller says whether that is an error."""
    largest = max((abs(v) for v in values), default=0.0)
    if largest == 0.0:
        return [0.0] * len(values), 0.0
    scaled = [v / largest for v in values]
    scaled_norm = math.hypot(*scaled)
    return [v / scaled_norm for v in scaled], largest * scaled_norm
