"""Trimesh meshes from the server's scene geometry: one mesh per body, geoms merged, coloured."""

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
    rgba = (np.clip(np.array(geom.rgba), 0.0, 1.0) * 255).astype(np.uint8)
    mesh.visual.vertex_colors = np.tile(rgba, (len(mesh.vertices), 1))
    return mesh


def body_meshes(geometry: GeometryModel) -> dict[str, trimesh.Trimesh]:
    """{body name: merged mesh in the body frame} for bodies that have something to draw."""
    per_body: dict[str, list[trimesh.Trimesh]] = {}
    for geom in geometry.geoms:
        part = geom_mesh(geom)
        if part is not None:
            per_body.setdefault(geom.body, []).append(part)
    merged: dict[str, trimesh.Trimesh] = {}
    for body, parts in per_body.items():
        mesh = trimesh.util.concatenate(parts)
        assert isinstance(mesh, trimesh.Trimesh)
        merged[body] = mesh
    return merged
