"""Trimesh meshes from the server's scene geometry: per body, one part per colour (so the view can
grey them all out by recolouring, when the state is stale)."""

from dataclasses import dataclass

import numpy as np
import trimesh

from server.models import GeometryModel, GeomModel


def geom_mesh(geom: GeomModel) -> trimesh.Trimesh | None:
    """The geom as a mesh in its body's frame (None for planes: the console draws a grid)."""
    size = geom.size
    if geom.type == "box":
        mesh = trimesh.creation.box(extents=[2 * size[0], 2 * size[1], 2 * size[2]])
    elif geom.type == "sphere":
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=size[0])
    elif geom.type == "capsule":
        mesh = trimesh.creation.capsule(height=2 * size[1], radius=size[0], count=[16, 16])
    elif geom.type == "cylinder":
        mesh = trimesh.creation.cylinder(radius=size[0], height=2 * size[1], sections=24)
    elif geom.type == "mesh" and geom.vertices and geom.faces:
        mesh = trimesh.Trimesh(np.array(geom.vertices), np.array(geom.faces), process=False)
    else:
        return None
    T_body_geom = trimesh.transformations.quaternion_matrix(geom.quat)  # w x y z
    T_body_geom[0:3, 3] = geom.pos
    mesh.apply_transform(T_body_geom)
    return mesh


@dataclass(frozen=True)
class MeshPart:
    mesh: trimesh.Trimesh  # in the body frame
    rgb: tuple[int, int, int]
    opacity: float


def body_parts(geometry: GeometryModel) -> dict[str, list[MeshPart]]:
    """{body name: its geoms merged per colour, in the body frame} for bodies with something to draw."""
    grouped: dict[str, dict[tuple[int, ...], list[trimesh.Trimesh]]] = {}
    for geom in geometry.geoms:
        part = geom_mesh(geom)
        if part is not None:
            rgba = tuple(int(c) for c in np.clip(np.array(geom.rgba), 0.0, 1.0) * 255)
            grouped.setdefault(geom.body, {}).setdefault(rgba, []).append(part)
    out: dict[str, list[MeshPart]] = {}
    for body, by_color in grouped.items():
        for rgba, meshes in by_color.items():
            mesh = trimesh.util.concatenate(meshes)
            assert isinstance(mesh, trimesh.Trimesh)
            out.setdefault(body, []).append(MeshPart(mesh, (rgba[0], rgba[1], rgba[2]), rgba[3] / 255))
    return out
