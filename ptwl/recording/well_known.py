"""The API's plain data as Foxglove's well-known messages (what its panels show unconfigured).

Poses arrive as `{"position": [x y z], "quaternion": [w x y z]}` or `[x y z qw qx qy qz]`;
Foxglove's quaternions are x y z w. Geoms are MuJoCo's: half-sizes, poses in their body's frame.
"""

import math
from typing import Any

import mujoco
import numpy as np
from foxglove.messages import (
    ArrowPrimitive,
    Color,
    CubePrimitive,
    CylinderPrimitive,
    Event,
    FrameTransform,
    JointState,
    JointStates,
    KeyValuePair,
    Log,
    LogLevel,
    Point3,
    Pose,
    PoseInFrame,
    Quaternion,
    SceneEntity,
    SceneEntityDeletion,
    SceneEntityDeletionType,
    SceneUpdate,
    SpherePrimitive,
    Timestamp,
    TriangleListPrimitive,
    Vector3,
)

from ptwl.recording.topics import BASE_FRAME, WORLD_BODY
from robot_sim.exit_severity import Severity, severity

FORCE_ARROW_M_PER_N = 0.005  # [m/N] 20 N draws a 10 cm arrow
FORCE_ARROW_MIN_N = 0.05  # [N] below this (sensor noise at rest) no arrow is drawn
FORCE_ARROW_ID = "measured_force"
PLANE_HALF_M = 1.0  # [m] a MuJoCo plane is infinite; drawn as a 2 m square
PLANE_HALF_THICK_M = 0.0005
_X_TO_Z = np.array([math.sqrt(0.5), 0.0, -math.sqrt(0.5), 0.0])  # rotates +x onto +z (w x y z)


def timestamp(ns: int) -> Timestamp:
    return Timestamp(ns // 1_000_000_000, ns % 1_000_000_000)


def vector(xyz: list[float]) -> Vector3:
    return Vector3(x=xyz[0], y=xyz[1], z=xyz[2])


def quaternion(wxyz: list[float]) -> Quaternion:
    """Ours are w x y z (MuJoCo's); Foxglove names its fields."""
    w, x, y, z = wxyz
    return Quaternion(x=x, y=y, z=z, w=w)


def pose_of(position: list[float], quat_wxyz: list[float]) -> Pose:
    return Pose(position=vector(position), orientation=quaternion(quat_wxyz))


def transform(
    ns: int, child: str, position: list[float], quat_wxyz: list[float], parent: str = BASE_FRAME
) -> FrameTransform:
    return FrameTransform(
        timestamp=timestamp(ns),
        parent_frame_id=parent,
        child_frame_id=child,
        translation=vector(position),
        rotation=quaternion(quat_wxyz),
    )


def pose_in_base(ns: int, pose: dict[str, list[float]]) -> PoseInFrame:
    return PoseInFrame(
        timestamp=timestamp(ns), frame_id=BASE_FRAME, pose=pose_of(pose["position"], pose["quaternion"])
    )


def joint_states(ns: int, names: tuple[str, ...], positions_rad: list[float]) -> JointStates:
    joints = [JointState(name=n, position=q) for n, q in zip(names, positions_rad, strict=True)]
    return JointStates(timestamp=timestamp(ns), joints=joints)


def force_arrow(ns: int, port_position: list[float], wrench: list[float]) -> SceneUpdate:
    """The measured force (environment on the port) as an arrow from the port, or none at rest."""
    force = np.asarray(wrench[:3], dtype=float)
    norm = float(np.linalg.norm(force))
    if not math.isfinite(norm) or norm < FORCE_ARROW_MIN_N:
        return SceneUpdate(
            deletions=[
                SceneEntityDeletion(
                    timestamp=timestamp(ns), type=SceneEntityDeletionType.MatchingId, id=FORCE_ARROW_ID
                )
            ]
        )
    quat_z = np.zeros(4)
    mujoco.mju_quatZ2Vec(quat_z, force / norm)
    quat_x = np.zeros(4)
    mujoco.mju_mulQuat(quat_x, quat_z, _X_TO_Z)  # the arrow primitive points along its +x
    length = norm * FORCE_ARROW_M_PER_N
    arrow = ArrowPrimitive(
        pose=pose_of(port_position, quat_x.tolist()),
        shaft_length=0.8 * length,
        shaft_diameter=0.006,
        head_length=0.2 * length,
        head_diameter=0.014,
        color=Color(r=1.0, g=0.55, b=0.0, a=1.0),
    )
    entity = SceneEntity(timestamp=timestamp(ns), frame_id=BASE_FRAME, id=FORCE_ARROW_ID, arrows=[arrow])
    return SceneUpdate(entities=[entity])


def scene_entities(ns: int, geometry: dict[str, Any]) -> SceneUpdate:
    """Every visible geom, one entity per body, drawn in that body's frame (its transform is on
    /tf); everything drawn before (an earlier scene's) is deleted first."""
    by_body: dict[str, dict[str, list[Any]]] = {}
    for geom in geometry["geoms"]:
        parts = by_body.setdefault(
            geom["body"], {"cubes": [], "spheres": [], "cylinders": [], "triangles": []}
        )
        _add_geom(parts, geom)
    entities = [
        SceneEntity(
            timestamp=timestamp(ns),
            frame_id=BASE_FRAME if body == WORLD_BODY else body,
            id=f"body:{body}",
            frame_locked=True,
            cubes=parts["cubes"],
            spheres=parts["spheres"],
            cylinders=parts["cylinders"],
            triangles=parts["triangles"],
        )
        for body, parts in by_body.items()
    ]
    clear = SceneEntityDeletion(timestamp=timestamp(ns), type=SceneEntityDeletionType.All, id="")
    return SceneUpdate(deletions=[clear], entities=entities)


def _add_geom(parts: dict[str, list[Any]], geom: dict[str, Any]) -> None:
    r, g, b, a = geom["rgba"]
    color = Color(r=r, g=g, b=b, a=a)
    pose = pose_of(geom["pos"], geom["quat"])
    size = geom["size"]
    kind = geom["type"]
    if kind == "box":
        parts["cubes"].append(
            CubePrimitive(pose=pose, size=Vector3(x=2 * size[0], y=2 * size[1], z=2 * size[2]), color=color)
        )
    elif kind == "plane":
        extent = Vector3(
            x=2 * (size[0] or PLANE_HALF_M), y=2 * (size[1] or PLANE_HALF_M), z=2 * PLANE_HALF_THICK_M
        )
        parts["cubes"].append(CubePrimitive(pose=pose, size=extent, color=color))
    elif kind == "sphere":
        d = 2 * size[0]
        parts["spheres"].append(SpherePrimitive(pose=pose, size=Vector3(x=d, y=d, z=d), color=color))
    elif kind in ("cylinder", "capsule"):
        d, length = 2 * size[0], 2 * size[1]
        parts["cylinders"].append(
            CylinderPrimitive(
                pose=pose, size=Vector3(x=d, y=d, z=length), bottom_scale=1.0, top_scale=1.0, color=color
            )
        )
        if kind == "capsule":  # the rounded ends
            for end in (-size[1], size[1]):
                centre = _in_body(geom, [0.0, 0.0, end])
                parts["spheres"].append(
                    SpherePrimitive(
                        pose=pose_of(centre, geom["quat"]), size=Vector3(x=d, y=d, z=d), color=color
                    )
                )
    elif kind == "mesh":
        vertices = geom["vertices"]
        points = [
            Point3(x=v[0], y=v[1], z=v[2]) for face in geom["faces"] for v in (vertices[i] for i in face)
        ]
        parts["triangles"].append(TriangleListPrimitive(pose=pose, points=points, color=color))


def _in_body(geom: dict[str, Any], point_in_geom: list[float]) -> list[float]:
    out = np.zeros(3)
    mujoco.mju_rotVecQuat(out, np.asarray(point_in_geom, dtype=float), np.asarray(geom["quat"], dtype=float))
    return (out + np.asarray(geom["pos"], dtype=float)).tolist()


LOG_LEVELS = {
    Severity.SUCCESS: LogLevel.Info,
    Severity.NOTICE: LogLevel.Warning,  # it did not run to its end: worth seeing in a log
    Severity.WARNING: LogLevel.Warning,
    Severity.ERROR: LogLevel.Error,
}


def log_level(exit_condition: str | None) -> LogLevel:
    """A log line's level: a command's end is as severe as its exit; anything else is info."""
    return LogLevel.Info if exit_condition is None else LOG_LEVELS[severity(exit_condition)]


def log_line(ns: int, name: str, text: str, exit_condition: str | None = None) -> Log:
    level = log_level(exit_condition)
    return Log(timestamp=timestamp(ns), level=level, message=text, name=name)


def command_event(start_ns: int, end_ns: int, fields: dict[str, str]) -> Event:
    return Event(
        start_time=timestamp(start_ns),
        end_time=timestamp(end_ns),
        metadata=[KeyValuePair(key=k, value=v) for k, v in fields.items()],
    )
