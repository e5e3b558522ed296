"""The robot's state as telemetry carries it: plain, strict-JSON data (GET /api/state, the
telemetry socket, recordings). One builder for the server and the virtual-time sweeps."""

import math
from typing import Any

from robot_sim.gains import Gains
from robot_sim.geometry import body_poses
from robot_sim.scenes import TaskProgress
from robot_sim.sim import Simulation
from robot_sim.task_frames import TaskFrames, frame_dict


def state_fields(sim: Simulation, moving: list[int]) -> dict[str, Any]:
    """The simulation's part of a state message (`moving`: geometry.moving_bodies of its model)."""
    state = sim.state()
    return {
        "sim_time": state.sim_time,
        "port": state.port.as_dict(),
        "attractor": state.attractor.as_dict(),
        "wrench": list(state.wrench),
        "joint_positions": list(state.joint_positions),
        "scene": state.scene,
        "manipulability": state.manipulability,
        "faults": sim.fault_count,
        "limited": state.limited,
        "bodies": body_poses(sim.model, sim.data, moving),
        "task": task_fields(sim.task()),
        "gains": gains_fields(sim.controller.gains),
        "monitor": sim.monitor.fields() if sim.monitor is not None else None,
    }


def frames_message(frames: TaskFrames) -> dict[str, Any]:
    """The `frames` message: every client (and recording) hears of the task frames through it,
    on each scene load and each change."""
    return {"type": "frames", "frames": [frame_dict(f) for f in frames.all()]}


def gains_fields(gains: Gains) -> dict[str, Any]:
    return {"stiffness": gains.stiffness.tolist(), "damping": gains.damping.tolist(), "frame": gains.frame}


def task_fields(progress: TaskProgress) -> dict[str, Any]:
    """The task predicate for telemetry; a non-finite progress (a fault mid-evaluation) is null,
    so every message stays strict JSON."""
    task = dict(progress.__dict__)
    if not math.isfinite(task["progress"]):
        task["progress"] = None
    return task
