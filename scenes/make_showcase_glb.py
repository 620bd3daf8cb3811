"""Writes scenes/showcase.glb, the glTF model of scenes/gltf-sky.toml, with trimesh's glTF
exporter (an independent writer: ember only reads it).

Run from the repository root:

    python scenes/make_showcase_glb.py

Needs trimesh 5.2.0 and numpy 1.26.4 (PyPI). Running it again writes the same bytes. The
committed file was made without scipy installed: trimesh then prints "unable to use sparse
matrix, falling back!" while computing vertex normals and uses its dense code instead.

Three meshes, each its own node and metallic-roughness material, Y up, units as
scenes/teapot.obj:
- the Utah teapot of scenes/teapot.obj (its corners welded, smooth vertex normals), gold:
  base colour (1.0, 0.77, 0.34), metallic 1, roughness 0.25 (ember: metal);
- a sphere of radius 1.1 (icosphere, 4 subdivisions, 2562 vertices), blue plastic: base colour
  (0.10, 0.25, 0.70), metallic 0, roughness 0.2 (ember: plastic);
- a low box (7.6 × 0.3 × 5.2) the teapot stands on, off-white, metallic 0, roughness 1 (ember: diffuse).
"""

import os

import numpy as np
import trimesh
from trimesh.visual.material import PBRMaterial
from trimesh.visual.texture import TextureVisuals

HERE = os.path.dirname(os.path.abspath(__file__))


def with_material(mesh, name, base, metallic, roughness):
    mat = PBRMaterial(
        name=name,
        baseColorFactor=[*base, 1.0],
        metallicFactor=metallic,
        roughnessFactor=roughness,
    )
    mesh.visual = TextureVisuals(material=mat)
    return mesh


def main():
    teapot = trimesh.load(os.path.join(HERE, "teapot.obj"), force="mesh", process=False)
    teapot.merge_vertices(merge_tex=True, merge_norm=True)
    teapot = trimesh.Trimesh(vertices=teapot.vertices, faces=teapot.faces, process=False)
    teapot = trimesh.Trimesh(
        vertices=teapot.vertices, faces=teapot.faces, vertex_normals=teapot.vertex_normals, process=False
    )
    with_material(teapot, "gold", (1.0, 0.77, 0.34), 1.0, 0.25)

    sphere = trimesh.creation.icosphere(subdivisions=4, radius=1.1)
    sphere = trimesh.Trimesh(
        vertices=sphere.vertices,
        faces=sphere.faces,
        vertex_normals=sphere.vertices / np.linalg.norm(sphere.vertices, axis=1)[:, None],
        process=False,
    )
    with_material(sphere, "blue-plastic", (0.10, 0.25, 0.70), 0.0, 0.2)

    box = trimesh.creation.box(extents=(7.6, 0.3, 5.2))
    with_material(box, "plinth", (0.80, 0.78, 0.74), 0.0, 1.0)

    scene = trimesh.Scene()
    scene.add_geometry(box, node_name="plinth", geom_name="plinth", transform=trimesh.transformations.translation_matrix((0.2, 0.15, 0.0)))
    scene.add_geometry(teapot, node_name="teapot", geom_name="teapot", transform=trimesh.transformations.translation_matrix((0.0, 0.3, 0.0)))
    scene.add_geometry(sphere, node_name="sphere", geom_name="sphere", transform=trimesh.transformations.translation_matrix((-5.2, 1.1, 2.6)))
    with open(os.path.join(HERE, "showcase.glb"), "wb") as out:
        out.write(scene.export(file_type="glb"))


if __name__ == "__main__":
    main()
