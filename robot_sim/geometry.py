"""The scene's geometry as plain data, for drawing it elsewhere (the console draws from this).

Every visible geom (groups 0-2) with its body, type, size, pose in the body frame and colour;
mesh geoms carry their vertices and faces. Bodies say whether they move (the arm, and any part
not welded to the world) and where they are now; moving bodies' poses then come with each telemetry message.
"""

from typing import Any

import mujoco
import numpy as np

from robot_sim.model import ARM_PREFIX

_TYPES = {
    int(mujoco.mjtGeom.mjGEOM_PLANE): "plane",
    int(mujoco.mjtGeom.mjGEOM_SPHERE): "sphere",
    int(mujoco.mjtGeom.mjGEOM_CAPSULE): "capsule",
    int(mujoco.mjtGeom.mjGEOM_CYLINDER): "cylinder",
    int(mujoco.mjtGeom.mjGEOM_BOX): "box",
    int(mujoco.mjtGeom.mjGEOM_MESH): "mesh",
}


def moving_bodies(model: mujoco.MjModel) -> list[int]:
    """The bodies whose poses telemetry carries: the arm's (its base too: a console draws the
    robot whole) and every other body not welded to the world (a fixture's moving parts, such as
    a latch collar)."""
    return [
        b
        for b in range(1, model.nbody)
        if model.body(b).name.startswith(ARM_PREFIX) or model.body_weldid[b] != 0
    ]


def body_poses(model: mujoco.MjModel, data: mujoco.MjData, bodies: list[int]) -> dict[str, list[float]]:
    """{body name: [x, y, z, qw, qx, qy, qz]} in the base frame."""
    return {model.body(b).name: [*data.xpos[b].tolist(), *data.xquat[b].tolist()] for b in bodies}


def scene_geometry(model: mujoco.MjModel, data: mujoco.MjData) -> dict[str, Any]:
    moving = set(moving_bodies(model))
    geoms = []
    for g in range(model.ngeom):
        kind = _TYPES.get(int(model.geom_type[g]))
        if model.geom_group[g] > 2 or kind is None:
            continue
        rgba = model.geom_rgba[g]
        if model.geom_matid[g] >= 0:
            rgba = model.mat_rgba[model.geom_matid[g]]
        geom: dict[str, Any] = {
            "name": model.geom(g).name,
            "body": model.body(model.geom_bodyid[g]).name,
            "type": kind,
            "size": model.geom_size[g].tolist(),  # MuJoCo's half-sizes / radii [m]
            "pos": model.geom_pos[g].tolist(),
            "quat": model.geom_quat[g].tolist(),
            "rgba": np.asarray(rgba, dtype=float).tolist(),
        }
        if kind == "mesh":
            mesh = model.geom_dataid[g]
            v0, nv = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
            f0, nf = model.mesh_faceadr[mesh], model.mesh_facenum[mesh]
            geom["vertices"] = model.mesh_vert[v0 : v0 + nv].tolist()
            geom["faces"] = model.mesh_face[f0 : f0 + nf].tolist()
        geoms.append(geom)
    bodies = {
        model.body(b).name: {"moving": b in moving, "pose": [*data.xpos[b].tolist(), *data.xquat[b].tolist()]}
        for b in range(model.nbody)
    }
    return {"bodies": bodies, "geoms": geoms}
