"""Where the arm lives inside a compiled model: ids, addresses and limits, resolved once."""

from dataclasses import dataclass

import mujoco
import numpy as np

from robot_sim.model import ARM_PREFIX, TOOL_PREFIX

N_JOINTS = 6
JOINT_NAMES = tuple(f"{ARM_PREFIX}j{i + 1}" for i in range(N_JOINTS))  # in joint_positions order


@dataclass(frozen=True)
class ArmLayout:
    """Indices of the arm's joints, servos, sites and sensor in one model."""

    qpos_adr: np.ndarray  # (6,) int: joint positions in qpos
    dof_adr: np.ndarray  # (6,) int: joint velocities in qvel, columns of the Jacobian
    act_adr: np.ndarray  # (6,) int: integrated-velocity servo states in act
    ctrl_pos: slice  # ctrl of the integrated-velocity (position) servos [rad/s]
    ctrl_vel: slice  # ctrl of the velocity feed-forward servos [rad/s]
    joint_range: np.ndarray  # (6, 2) [rad]
    joint_speed_limit: np.ndarray  # (6,) [rad/s]
    port_site: int  # port of interaction (tool frame, z out of the tool)
    ft_site: int  # force/torque sensor measuring frame
    ft_sensor_adr: int  # sensordata[adr:adr+6] = force (3) then torque (3), ft site frame
    tool_body: int

    @staticmethod
    def from_model(model: mujoco.MjModel) -> "ArmLayout":
        joints = [model.joint(name) for name in JOINT_NAMES]
        dof_adr = np.array([j.dofadr[0] for j in joints])
        # The hot loop takes the first six Jacobian columns without a gather; scenes must add
        # free bodies after the arm.
        if not np.array_equal(dof_adr, np.arange(N_JOINTS)):
            raise ValueError(f"arm joints must be the model's first 6 dofs, got {dof_adr}")
        pos_servos = [model.actuator(f"{ARM_PREFIX}servo_p{i + 1}") for i in range(N_JOINTS)]
        vel_servos = [model.actuator(f"{ARM_PREFIX}servo_v{i + 1}") for i in range(N_JOINTS)]
        p_ids = [a.id for a in pos_servos]
        v_ids = [a.id for a in vel_servos]
        if p_ids != list(range(6)) or v_ids != list(range(6, 12)):
            raise ValueError("servo actuators must be ctrl[0:6] (position) and ctrl[6:12]")
        force = model.sensor(f"{ARM_PREFIX}{TOOL_PREFIX}ft_force")
        torque = model.sensor(f"{ARM_PREFIX}{TOOL_PREFIX}ft_torque")
        if torque.adr[0] != force.adr[0] + 3:
            raise ValueError("ft torque sensor must follow the force sensor in sensordata")
        return ArmLayout(
            qpos_adr=np.array([j.qposadr[0] for j in joints]),
            dof_adr=dof_adr,
            act_adr=np.array([model.actuator_actadr[i] for i in p_ids]),
            ctrl_pos=slice(0, 6),
            ctrl_vel=slice(6, 12),
            joint_range=np.array([j.range for j in joints], dtype=float),
            joint_speed_limit=np.array(model.numeric(f"{ARM_PREFIX}joint_speed_limits").data),
            port_site=model.site(f"{ARM_PREFIX}{TOOL_PREFIX}port").id,
            ft_site=model.site(f"{ARM_PREFIX}{TOOL_PREFIX}ft").id,
            ft_sensor_adr=int(force.adr[0]),
            tool_body=model.body(f"{ARM_PREFIX}{TOOL_PREFIX}tool").id,
        )
