"""Two large glTF files for timing instancing (docs/performance.md, "Instancing"), written by
Blender's own glTF exporter: one icosphere of 20,480 triangles (Blender's subdivisions 6) placed by 64
nodes on an 8 x 8 grid, once as linked duplicates (one mesh, 64 nodes: `inst_linked.glb`) and
once as 64 single-user copies (64 meshes: `inst_copies.glb`, 1.3 M triangles).

    /work/venvs/bpy/bin/python scripts/assets/make_instancing_bench.py OUT_DIR   # ~1 min
    ember info OUT_DIR/inst_linked.glb; ember info OUT_DIR/inst_copies.glb

The venv is the one of make_gltf_assets.py (PyPI bpy 4.5.15). The files are not kept in the
repository (the copies file is 95 MB).
"""
import os
import sys

import numpy  # noqa: F401  (bpy wants numpy importable first)
import bpy  # noqa: E402

OUT = sys.argv[1]
os.makedirs(OUT, exist_ok=True)


def scene(copies):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=6, radius=0.2)
    src = bpy.context.active_object
    me = src.data
    bpy.data.objects.remove(src)
    for k in range(64):
        ob = bpy.data.objects.new(f"ico.{k:02d}", me.copy() if copies else me)
        ob.location = (0.5 * (k % 8), 0.5 * (k // 8), 0.0)
        bpy.context.scene.collection.objects.link(ob)
    path = os.path.join(OUT, "inst_copies.glb" if copies else "inst_linked.glb")
    bpy.ops.export_scene.gltf(filepath=path, export_format="GLB", export_cameras=False, export_lights=False,
                              export_materials="NONE", export_normals=True, export_texcoords=False)
    print(f"{path}: {os.path.getsize(path)} bytes")


scene(copies=False)
scene(copies=True)
