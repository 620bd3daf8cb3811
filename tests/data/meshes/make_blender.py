"""Writes the Blender-made test files of tests/data/meshes/ (see README.md there).

Run with Blender as a Python module (PyPI `bpy` 4.5.15 on Python 3.11), from the repository root:

    python tests/data/meshes/make_blender.py

Blender builds a small scene — the Utah teapot of scenes/teapot.obj welded and decimated to
about 400 triangles with a plastic-like material, a metal cube parented under a rotated,
scaled empty with a checker base colour texture, an emissive glass icosphere, a perspective camera, a
point light and a sun — and exports it with its own glTF exporter as .gltf + .bin + .png
and as .glb, and a quad cube with its own PLY exporter (ASCII and binary little-endian).
"""

import math
import os
import sys

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", "..", ".."))


def clear():
    bpy.ops.wm.read_factory_settings(use_empty=True)


def principled(name, base, metallic, roughness):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    p = m.node_tree.nodes["Principled BSDF"]
    p.inputs["Base Color"].default_value = (*base, 1.0)
    p.inputs["Metallic"].default_value = metallic
    p.inputs["Roughness"].default_value = roughness
    return m, p


def scene():
    clear()
    # The teapot, welded (the OBJ is an unwelded surface) and decimated.
    bpy.ops.wm.obj_import(filepath=os.path.join(ROOT, "scenes", "teapot.obj"), forward_axis="NEGATIVE_Z", up_axis="Y")
    teapot = bpy.context.selected_objects[0]
    teapot.name = "teapot"
    bpy.context.view_layer.objects.active = teapot
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.mesh.remove_doubles(threshold=1e-4)
    bpy.ops.object.mode_set(mode="OBJECT")
    dec = teapot.modifiers.new("decimate", "DECIMATE")
    dec.ratio = 0.065
    bpy.ops.object.modifier_apply(modifier="decimate")
    teapot.location = (0.0, 0.0, 0.0)
    teapot.rotation_euler = (math.radians(90), 0.0, math.radians(30))
    m, _ = principled("teapot-plastic", (0.62, 0.08, 0.05), 0.0, 0.3)
    teapot.data.materials.clear()
    teapot.data.materials.append(m)

    # A metal cube under a rotated, scaled empty: the exporter writes a node hierarchy.
    bpy.ops.object.empty_add(location=(4.0, 0.0, 0.5))
    pivot = bpy.context.object
    pivot.name = "pivot"
    pivot.rotation_euler = (0.0, 0.0, math.radians(20))
    pivot.scale = (0.5, 0.5, 0.5)
    bpy.ops.mesh.primitive_cube_add(size=2.0)
    cube = bpy.context.object
    cube.name = "cube"
    cube.parent = pivot
    cube.location = (0.0, 1.0, 0.0)
    m, p = principled("cube-metal", (0.9, 0.9, 0.92), 1.0, 0.2)
    # A base colour texture: Blender's 16x16 colour grid, saved as PNG.
    img = bpy.data.images.new("checker", 16, 16)
    img.generated_type = "COLOR_GRID"
    img.filepath_raw = os.path.join(HERE, "checker.png")
    img.file_format = "PNG"
    img.save()
    tex = m.node_tree.nodes.new("ShaderNodeTexImage")
    tex.image = img
    m.node_tree.links.new(tex.outputs["Color"], p.inputs["Base Color"])
    cube.data.materials.append(m)

    # An emissive glass icosphere.
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=2, radius=0.8, location=(-3.5, 0.5, 0.8))
    ico = bpy.context.object
    ico.name = "icosphere"
    bpy.ops.object.shade_smooth()
    m, p = principled("ico-glass", (1.0, 1.0, 1.0), 0.0, 0.0)
    p.inputs["Transmission Weight"].default_value = 1.0
    p.inputs["IOR"].default_value = 1.45
    p.inputs["Emission Color"].default_value = (1.0, 0.5, 0.25, 1.0)
    p.inputs["Emission Strength"].default_value = 2.0
    ico.data.materials.append(m)

    bpy.ops.object.camera_add(location=(9.0, -11.0, 7.0))
    cam = bpy.context.object
    cam.name = "camera"
    cam.data.type = "PERSP"
    cam.data.sensor_fit = "VERTICAL"
    cam.data.angle_y = math.radians(35.0)
    target = bpy.data.objects.new("target", None)
    bpy.context.collection.objects.link(target)
    target.location = (0.0, 0.0, 1.0)
    track = cam.constraints.new("TRACK_TO")
    track.target = target
    track.track_axis = "TRACK_NEGATIVE_Z"
    track.up_axis = "UP_Y"
    bpy.context.view_layer.update()
    # Bake the constraint into the transform (the exporter writes the evaluated transform too,
    # but a plain matrix keeps the file independent of constraint support).
    cam.matrix_world = cam.matrix_world.copy()
    mw = cam.matrix_world.copy()
    cam.constraints.remove(track)
    cam.matrix_world = mw

    bpy.ops.object.light_add(type="POINT", location=(2.0, -3.0, 6.0))
    bpy.context.object.name = "lamp"
    bpy.context.object.data.energy = 1000.0
    bpy.context.object.data.color = (1.0, 0.9, 0.8)
    bpy.context.object.data.shadow_soft_size = 0.0
    bpy.ops.object.light_add(type="SUN", location=(0.0, 0.0, 10.0))
    bpy.context.object.name = "sun"

    common = dict(export_cameras=True, export_lights=True, export_yup=True, export_apply=True)
    bpy.ops.export_scene.gltf(filepath=os.path.join(HERE, "scene.gltf"), export_format="GLTF_SEPARATE", **common)
    bpy.ops.export_scene.gltf(filepath=os.path.join(HERE, "scene.glb"), export_format="GLB", **common)


def quad_cube():
    clear()
    bpy.ops.mesh.primitive_cube_add(size=2.0, location=(0.0, 0.0, 0.0))
    cube = bpy.context.object
    cube.name = "quadcube"
    # Corner colours, so the PLY carries vertex colours.
    attr = cube.data.color_attributes.new("Col", "BYTE_COLOR", "POINT")
    for i, v in enumerate(cube.data.vertices):
        attr.data[i].color_srgb = (v.co.x * 0.5 + 0.5, v.co.y * 0.5 + 0.5, v.co.z * 0.5 + 0.5, 1.0)
    common = dict(
        export_selected_objects=False,
        export_normals=True,
        export_uv=True,
        export_colors="SRGB",
        export_triangulated_mesh=False,
        forward_axis="NEGATIVE_Z",
        up_axis="Y",
    )
    bpy.ops.wm.ply_export(filepath=os.path.join(HERE, "quadcube-ascii.ply"), ascii_format=True, **common)
    bpy.ops.wm.ply_export(filepath=os.path.join(HERE, "quadcube-le.ply"), ascii_format=False, **common)


if __name__ == "__main__":
    print("bpy", bpy.app.version_string, file=sys.stderr)
    scene()
    quad_cube()
