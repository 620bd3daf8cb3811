"""Writes the trimesh/plyfile-made test files of tests/data/meshes/ (see README.md there).

Run from the repository root, after make_blender.py (it reads scene.glb):

    python tests/data/meshes/make_trimesh.py

Needs trimesh 5.2.0, plyfile 1.1.3 and numpy 1.26.4 (PyPI).
"""

import os

import numpy as np
import plyfile
import trimesh

HERE = os.path.dirname(os.path.abspath(__file__))


def g9(x):
    """A float32 written so that it reads back exactly (9 significant digits)."""
    return "%.9g" % float(np.float32(x))


def write_obj(path, objects, comment):
    """OBJ with `o` blocks of positions, normals and triangles, every number exact for f32."""
    lines = [f"# {comment}"]
    base = 1
    for name, positions, normals, faces in objects:
        lines.append(f"o {name}")
        for p in positions:
            lines.append("v " + " ".join(g9(c) for c in p))
        for n in normals:
            lines.append("vn " + " ".join(g9(c) for c in n))
        for f in faces:
            lines.append("f " + " ".join(f"{base + int(i)}//{base + int(i)}" for i in f))
        base += len(positions)
    with open(path, "w") as out:
        out.write("\n".join(lines) + "\n")


def icosphere():
    # 2 subdivisions: 162 vertices, 320 triangles. Normals are the unit positions.
    ico = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
    v = ico.vertices.astype(np.float32)
    n = (ico.vertices / np.linalg.norm(ico.vertices, axis=1)[:, None]).astype(np.float32)
    f = ico.faces
    # Texture coordinates and colours from the position (any values do: they are only read).
    uv = np.stack([v[:, 0] * 0.5 + 0.5, v[:, 1] * 0.5 + 0.5], axis=1).astype(np.float32)
    rgb = np.clip((v * 0.5 + 0.5) * 255.0, 0, 255).astype(np.uint8)
    rgba = np.concatenate([rgb, np.full((len(v), 1), 255, np.uint8)], axis=1)
    mesh = trimesh.Trimesh(vertices=v, faces=f, vertex_normals=n, vertex_colors=rgba, process=False)
    with open(os.path.join(HERE, "icosphere-ascii.ply"), "wb") as out:
        out.write(trimesh.exchange.ply.export_ply(mesh, encoding="ascii", vertex_normal=True))
    with open(os.path.join(HERE, "icosphere-le.ply"), "wb") as out:
        out.write(trimesh.exchange.ply.export_ply(mesh, encoding="binary", vertex_normal=True))
    # Big-endian with plyfile: double positions, float normals, `u v`, uchar colours, and the
    # face list named `vertex_index` with int counts and indices.
    vert = np.empty(
        len(v),
        dtype=[("x", ">f8"), ("y", ">f8"), ("z", ">f8"), ("nx", ">f4"), ("ny", ">f4"), ("nz", ">f4"),
               ("u", ">f4"), ("v", ">f4"), ("red", "u1"), ("green", "u1"), ("blue", "u1")],
    )
    for i, k in enumerate("xyz"):
        vert[k] = v[:, i].astype(np.float64)
        vert["n" + k] = n[:, i]
    vert["u"], vert["v"] = uv[:, 0], uv[:, 1]
    vert["red"], vert["green"], vert["blue"] = rgb[:, 0], rgb[:, 1], rgb[:, 2]
    face = np.empty(len(f), dtype=[("vertex_index", ">i4", (3,))])
    face["vertex_index"] = f.astype(np.int32)
    ply = plyfile.PlyData(
        [
            plyfile.PlyElement.describe(vert, "vertex"),
            plyfile.PlyElement.describe(face, "face", len_types={"vertex_index": "i4"}),
        ],
        byte_order=">",
        comments=["plyfile"],
    )
    ply.write(os.path.join(HERE, "icosphere-be.ply"))
    write_obj(
        os.path.join(HERE, "icosphere.obj"),
        [("icosphere", v, n, f)],
        "trimesh icosphere(subdivisions=2): the same vertices, normals and triangles as icosphere-*.ply",
    )


def scene_reference():
    """scene.glb as trimesh reads it, in world space, as OBJ (teapot, cube, icosphere)."""
    scene = trimesh.load(os.path.join(HERE, "scene.glb"), process=False)
    objects = []
    for node in ["teapot", "cube", "icosphere"]:
        transform, geometry_name = scene.graph.get(node)
        mesh = scene.geometry[geometry_name]
        m = np.asarray(transform, dtype=np.float64)
        p = np.asarray(mesh.vertices, dtype=np.float64)
        world = (p @ m[:3, :3].T + m[:3, 3]).astype(np.float32)
        # Normals as the glTF stores them (trimesh keeps them when process=False), by the
        # inverse transpose, normalised.
        nrm = np.asarray(mesh.vertex_normals, dtype=np.float64)
        nm = np.linalg.inv(m[:3, :3]).T
        wn = nrm @ nm.T
        wn = (wn / np.linalg.norm(wn, axis=1)[:, None]).astype(np.float32)
        objects.append((node, world, wn, np.asarray(mesh.faces)))
    write_obj(
        os.path.join(HERE, "scene-reference.obj"),
        objects,
        "scene.glb read by trimesh " + trimesh.__version__ + " (process=False), node transforms applied",
    )


if __name__ == "__main__":
    icosphere()
    scene_reference()
