#!/usr/bin/env python3
"""Make the glTF test assets in tests/data/gltf/, each with tools nobody here wrote.

Every asset covers one feature of glTF 2.0's material model so that a test can check it; the
facts a test needs (coverage, tilt, pattern, values) are in tests/data/gltf/SOURCES.md, and
this script prints the measured ones (alpha coverage, file sizes) as it goes.

The scenes are built in Blender through its Python module (PyPI `bpy`, which carries Blender's
own glTF add-on `io_scene_gltf2`) and written by that add-on's exporter
(`bpy.ops.export_scene.gltf`, GLB); the Draco file is written by the same exporter with its
bundled Draco library (`export_draco_mesh_compression_enable`). One asset is written by
trimesh's glTF exporter instead (`instanced_copies_trimesh.glb`, from Blender's geometry). Textures are drawn here with numpy
and saved as PNG by Pillow; the exporters embed them.

Coordinates: Blender is Z up, glTF Y up; the exporter maps a Blender point (x, y, z) to glTF
(x, z, -y). Geometry is placed here in Blender coordinates with `gl()` converting from the glTF
coordinates the facts are stated in. Blender's UV v runs up the image, glTF's down: the
exporter writes v_gltf = 1 - v_blender; the textures here are drawn as images (row 0 = top =
v_gltf 0).

Setup (Debian 12; bpy 4.5 needs Python 3.11 exactly and numpy < 2):
    python3.11 -m venv /work/venvs/bpy && /work/venvs/bpy/bin/pip install \
        bpy==4.5.15 'numpy<2' pillow OpenEXR trimesh
Command, from the repository root (~20 s):
    /work/venvs/bpy/bin/python scripts/assets/make_gltf_assets.py [OUT_DIR]
OUT_DIR defaults to tests/data/gltf. Rerunning writes the same bytes (checked with sha256sum).
"""
import math
import os
import sys
import tempfile

import numpy as np
from PIL import Image

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.normpath(os.path.join(HERE, "..", ".."))
OUT = os.path.abspath(sys.argv[1]) if len(sys.argv) > 1 else os.path.join(REPO, "tests", "data", "gltf")
TMP = tempfile.mkdtemp(prefix="gltf-assets-")

import bpy  # noqa: E402  (after numpy: bpy wants numpy < 2 already imported or importable)
import addon_utils  # noqa: E402
from mathutils import Vector  # noqa: E402

addon_utils.enable("io_scene_gltf2")
from io_scene_gltf2.blender.com.conversion import texture_transform_gltf_to_blender  # noqa: E402
from io_scene_gltf2.blender.com.material_helpers import create_settings_group  # noqa: E402

TILT_DEG = 20.0
ALPHA_CUTOFF = 0.3


# ================================================================= helpers
def gl(x, y, z):
    """A glTF point/vector (Y up) in Blender coordinates (Z up)."""
    return (x, -z, y)


def new_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    for img in list(bpy.data.images):
        bpy.data.images.remove(img)


def srgb_u8(linear):
    c = np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0)
    s = np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1.0 / 2.4) - 0.055)
    return np.round(s * 255.0).astype(np.uint8)


def image(name, pixels, colorspace):
    """`pixels`: uint8 HxWx{3,4}, row 0 = top of the image (glTF v = 0)."""
    path = os.path.join(TMP, name + ".png")
    Image.fromarray(pixels).save(path, optimize=True)
    img = bpy.data.images.load(path)
    img.name = name
    img.colorspace_settings.name = colorspace
    img.pack()
    return img


def link_object(name, mesh, location=(0, 0, 0), rotation=(0, 0, 0), scale=(1, 1, 1)):
    ob = bpy.data.objects.new(name, mesh)
    ob.location = location
    ob.rotation_euler = rotation
    ob.scale = scale
    bpy.context.scene.collection.objects.link(ob)
    return ob


def quad_mesh(name, corners, uvs_gltf, uv1_gltf=None):
    """A quad from 4 glTF corners (counter-clockwise seen from its front) with glTF UVs."""
    me = bpy.data.meshes.new(name)
    me.from_pydata([gl(*c) for c in corners], [], [(0, 1, 2, 3)])
    for layer_name, uvs in (("UVMap", uvs_gltf), ("UVMap.001", uv1_gltf)):
        if uvs is None:
            continue
        uv = me.uv_layers.new(name=layer_name)
        for loop in me.loops:
            u, v = uvs[loop.vertex_index]
            uv.data[loop.index].uv = (u, 1.0 - v)
    me.update()
    return me


def xy_quad(name, cx, cy, half, uv_lo=0.0, uv_hi=1.0, uv1=None):
    """A square in the glTF XY plane (facing +Z) centred at (cx, cy, 0); u along +X, v_gltf
    along -Y (so the image appears upright to a camera on +Z looking at -Z)."""
    corners = [(cx - half, cy - half, 0), (cx + half, cy - half, 0), (cx + half, cy + half, 0), (cx - half, cy + half, 0)]
    uvs = [(uv_lo, uv_hi), (uv_hi, uv_hi), (uv_hi, uv_lo), (uv_lo, uv_lo)]
    return quad_mesh(name, corners, uvs, uv1)


def xz_plane(name, half):
    """A square in the glTF XZ plane facing +Y; u along +X, v_gltf along +Z."""
    corners = [(-half, 0, half), (half, 0, half), (half, 0, -half), (-half, 0, -half)]
    uvs = [(0, 1), (1, 1), (1, 0), (0, 0)]
    return quad_mesh(name, corners, uvs)


def uv_sphere(name, segments=32, rings=16, radius=1.0):
    """A smooth UV sphere about glTF +Y (Blender +Z), triangles only, with Blender's UV layout:
    u = longitude / 360 degrees from +X (glTF) towards -Z (glTF), v_gltf = colatitude / 180
    degrees (0 at the north pole, +Y). Built here rather than by `primitive_uv_sphere_add`,
    whose face order changes from run to run (and with it the exported file's bytes)."""
    verts, tris, uvs = [(0.0, 0.0, radius)], [], []
    for k in range(1, rings):
        phi = math.pi * k / rings
        for j in range(segments):
            th = 2.0 * math.pi * j / segments
            verts.append((radius * math.sin(phi) * math.cos(th), radius * math.sin(phi) * math.sin(th),
                          radius * math.cos(phi)))
    verts.append((0.0, 0.0, -radius))
    south = len(verts) - 1

    def ring(k, j):                                   # k = 1 .. rings-1
        return 1 + (k - 1) * segments + j % segments

    def add(tri, uv):                                 # uv: glTF (u, v) per corner
        a, b, c = (Vector(verts[i]) for i in tri)
        if (b - a).cross(c - a).dot(a + b + c) < 0.0:   # outward, counter-clockwise
            tri, uv = tri[::-1], uv[::-1]
        tris.append(tri)
        uvs.extend(uv)

    for j in range(segments):
        u0, u1, um = j / segments, (j + 1) / segments, (j + 0.5) / segments
        add((0, ring(1, j), ring(1, j + 1)), [(um, 0.0), (u0, 1 / rings), (u1, 1 / rings)])
        for k in range(1, rings - 1):
            v0, v1 = k / rings, (k + 1) / rings
            q = (ring(k, j), ring(k + 1, j), ring(k + 1, j + 1), ring(k, j + 1))
            quv = [(u0, v0), (u0, v1), (u1, v1), (u1, v0)]
            add((q[0], q[1], q[2]), [quv[0], quv[1], quv[2]])
            add((q[0], q[2], q[3]), [quv[0], quv[2], quv[3]])
        add((south, ring(rings - 1, j + 1), ring(rings - 1, j)),
            [(um, 1.0), (u1, (rings - 1) / rings), (u0, (rings - 1) / rings)])
    me = bpy.data.meshes.new(name)
    me.from_pydata(verts, [], tris)
    uv = me.uv_layers.new(name="UVMap")
    for li, (u, v) in enumerate(uvs):
        uv.data[li].uv = (u, 1.0 - v)
    me.shade_smooth()
    me.update()
    return link_object(name, me)


class Mat:
    """A Principled BSDF material and helpers to wire textures into it."""

    def __init__(self, name, base=(0.8, 0.8, 0.8), metallic=0.0, roughness=0.5, ior=1.5):
        self.m = bpy.data.materials.new(name)
        self.m.use_nodes = True
        self.nt = self.m.node_tree
        self.p = self.nt.nodes["Principled BSDF"]
        self.out = self.nt.nodes["Material Output"]
        self.set(**{"Base Color": (*base, 1.0), "Metallic": metallic, "Roughness": roughness, "IOR": ior})

    def set(self, **inputs):
        for k, v in inputs.items():
            self.p.inputs[k].default_value = v
        return self

    def node(self, kind, **props):
        n = self.nt.nodes.new(kind)
        for k, v in props.items():
            setattr(n, k, v)
        return n

    def link(self, a, b):
        self.nt.links.new(a, b)

    def tex(self, img, extension="REPEAT", uv_map=None, interpolation="Linear"):
        t = self.node("ShaderNodeTexImage", image=img, extension=extension, interpolation=interpolation)
        if uv_map:
            uvn = self.node("ShaderNodeUVMap", uv_map=uv_map)
            self.link(uvn.outputs["UV"], t.inputs["Vector"])
        return t


def export(name, draco=False, tangents=False, **extra):
    path = os.path.join(OUT, name)
    bpy.ops.export_scene.gltf(
        filepath=path, export_format="GLB", export_yup=True, export_apply=False, use_selection=False,
        export_cameras=False, export_lights=False, export_extras=False, export_animations=False,
        export_image_format="AUTO", export_texcoords=True, export_normals=True, export_tangents=tangents,
        export_materials="EXPORT", export_draco_mesh_compression_enable=draco, **extra)
    print(f"{name}: {os.path.getsize(path)} bytes")
    return path


# ================================================================= textures
def blocks_texture():
    """64x64, 4x4 blocks of 16x16 texels; block (column i, row j), row 0 at the top:
    sRGB (round(255 (i + 0.5) / 4), round(255 (j + 0.5) / 4), 51) — distinct in every block,
    so a lookup's block says where it landed."""
    a = np.zeros((64, 64, 3), np.uint8)
    for j in range(4):
        for i in range(4):
            a[16 * j:16 * j + 16, 16 * i:16 * i + 16] = (round(255 * (i + 0.5) / 4), round(255 * (j + 0.5) / 4), 51)
    return a


def tilt_rgb(tx, ty, tz):
    """A tangent-space normal encoded as an 8-bit texel: round(255 (n + 1) / 2)."""
    n = np.array([tx, ty, tz], np.float64)
    n /= np.linalg.norm(n)
    return tuple(int(v) for v in np.round(255.0 * (n + 1.0) / 2.0))


S, C = math.sin(math.radians(TILT_DEG)), math.cos(math.radians(TILT_DEG))


# ================================================================= assets
def metal_rough_sphere():
    """Base colour and metallic-roughness textures varying over one sphere."""
    new_scene()
    ob = uv_sphere("metal_rough_sphere", 48, 24)
    mr = np.zeros((64, 64, 3), np.uint8)
    base = np.zeros((64, 64, 3), np.uint8)
    rough = [0.1, 0.3, 0.6, 0.9]                      # by latitude band, north (row 0) first
    colours = [(1.0, 0.766, 0.336), (0.8, 0.1, 0.1), (0.97, 0.96, 0.915), (0.8, 0.8, 0.8)]  # linear
    for j in range(4):
        for s in range(8):                            # 8 longitude sectors of 8 columns
            metal = 1.0 if s % 2 == 0 else 0.0
            mr[16 * j:16 * j + 16, 8 * s:8 * s + 8] = (255, round(255 * rough[j]), round(255 * metal))
            base[16 * j:16 * j + 16, 8 * s:8 * s + 8] = srgb_u8(colours[s % 4])
    m = Mat("metal_rough", metallic=0.0, roughness=0.5)
    tb = m.tex(image("mr_base", base, "sRGB"))
    m.link(tb.outputs["Color"], m.p.inputs["Base Color"])
    tm = m.tex(image("mr_metal_rough", mr, "Non-Color"))
    sep = m.node("ShaderNodeSeparateColor")
    m.link(tm.outputs["Color"], sep.inputs["Color"])
    m.link(sep.outputs["Green"], m.p.inputs["Roughness"])
    m.link(sep.outputs["Blue"], m.p.inputs["Metallic"])
    ob.data.materials.append(m.m)
    export("metal_rough_sphere.glb")


def normal_planes():
    """A 2x2 plane facing +Y whose normal map tilts the shading normal 20 degrees towards +X;
    with and without TANGENT; the same plane tilted geometrically; a quadrant map (no TANGENT)."""
    flat = tilt_rgb(S, 0.0, C)
    for name, tangents in (("normal_tilt20.glb", True), ("normal_tilt20_mikk.glb", False)):
        new_scene()
        ob = link_object("plane", xz_plane("plane", 1.0))
        m = Mat("normal_tilt20", base=(0.8, 0.8, 0.8), roughness=0.5)
        t = m.tex(image("normal_tilt20", np.full((64, 64, 3), flat, np.uint8), "Non-Color"))
        nm = m.node("ShaderNodeNormalMap", uv_map="UVMap")
        m.link(t.outputs["Color"], nm.inputs["Color"])
        m.link(nm.outputs["Normal"], m.p.inputs["Normal"])
        ob.data.materials.append(m.m)
        export(name, tangents=tangents)
    # the reference: the plane itself rotated so that its normal is (sin 20, cos 20, 0)
    new_scene()
    ob = link_object("plane", xz_plane("plane", 1.0), rotation=(0.0, math.radians(TILT_DEG), 0.0))
    # Blender's +Y rotation by +20 degrees turns +Z (glTF +Y) towards +X: normal (sin, 0, cos)
    # in Blender = glTF (sin 20, cos 20, 0)
    m = Mat("geometric_tilt20", base=(0.8, 0.8, 0.8), roughness=0.5)
    ob.data.materials.append(m.m)
    export("normal_tilt20_geometric.glb")
    # quadrants: glTF x<0,z<0 -> towards -X; x>0,z<0 -> +X; x<0,z>0 -> -Z; x>0,z>0 -> +Z.
    # Image column < 32 is u < 0.5 (x < 0); image row < 32 is v_gltf < 0.5 (z < 0). The
    # bitangent (green +) points up the image: towards v_gltf = 0, i.e. -Z.
    new_scene()
    ob = link_object("plane", xz_plane("plane", 1.0))
    q = np.zeros((64, 64, 3), np.uint8)
    q[:32, :32] = tilt_rgb(-S, 0.0, C)
    q[:32, 32:] = tilt_rgb(S, 0.0, C)
    q[32:, :32] = tilt_rgb(0.0, S, C)
    q[32:, 32:] = tilt_rgb(0.0, -S, C)
    m = Mat("normal_quadrants", base=(0.8, 0.8, 0.8), roughness=0.5)
    t = m.tex(image("normal_quadrants", q, "Non-Color"), interpolation="Closest")
    nm = m.node("ShaderNodeNormalMap", uv_map="UVMap")
    m.link(t.outputs["Color"], nm.inputs["Color"])
    m.link(nm.outputs["Normal"], m.p.inputs["Normal"])
    ob.data.materials.append(m.m)
    export("normal_quadrants_mikk.glb", tangents=False)
    # a sphere with the same quadrant map, with Blender's MikkTSpace tangents and without
    for name, tangents in (("normal_sphere.glb", True), ("normal_sphere_mikk.glb", False)):
        new_scene()
        ob = uv_sphere("normal_sphere", 32, 16)
        m = Mat("normal_sphere", base=(0.8, 0.8, 0.8), roughness=0.4)
        t = m.tex(image("normal_quadrants", q, "Non-Color"), interpolation="Closest")
        nm = m.node("ShaderNodeNormalMap", uv_map="UVMap")
        m.link(t.outputs["Color"], nm.inputs["Color"])
        m.link(nm.outputs["Normal"], m.p.inputs["Normal"])
        ob.data.materials.append(m.m)
        export(name, tangents=tangents)


def samplers():
    """Four quads (UVs -1..3) with one texture under REPEAT, MIRRORED_REPEAT, CLAMP_TO_EDGE and
    S = MIRRORED_REPEAT x T = CLAMP_TO_EDGE."""
    new_scene()
    img = image("blocks", blocks_texture(), "sRGB")
    for k, (mode, ext) in enumerate((("repeat", "REPEAT"), ("mirror", "MIRROR"), ("clamp", "EXTEND"),
                                     ("mirror_clamp", "EXTEND"))):
        ob = link_object(mode, xy_quad(mode, -1.65 + 1.1 * k, 0.0, 0.5, -1.0, 3.0))
        m = Mat("sampler_" + mode, roughness=0.8)
        t = m.tex(img, extension=ext)
        if mode == "mirror_clamp":   # per-axis wrap: the node setup Blender's importer makes for it
            uvn = m.node("ShaderNodeUVMap", uv_map="UVMap")
            sep = m.node("ShaderNodeSeparateXYZ")
            pp = m.node("ShaderNodeMath", operation="PINGPONG")
            pp.inputs[1].default_value = 1.0
            comb = m.node("ShaderNodeCombineXYZ")
            m.link(uvn.outputs["UV"], sep.inputs["Vector"])
            m.link(sep.outputs["X"], pp.inputs[0])
            m.link(pp.outputs["Value"], comb.inputs["X"])
            m.link(sep.outputs["Y"], comb.inputs["Y"])
            m.link(comb.outputs["Vector"], t.inputs["Vector"])
        m.link(t.outputs["Color"], m.p.inputs["Base Color"])
        ob.data.materials.append(m.m)
    export("samplers.glb")


TT = {"offset": [0.25, -0.1], "rotation": math.radians(30.0), "scale": [2.0, 1.5]}


def texture_transform():
    """A quad whose base colour texture has KHR_texture_transform; and the same quad with the
    transform baked into its UVs (the two should render the same)."""
    new_scene()
    ob = link_object("quad", xy_quad("quad", 0.0, 0.0, 1.0))
    m = Mat("texture_transform", roughness=0.8)
    t = m.tex(image("blocks", blocks_texture(), "sRGB"))
    uvn = m.node("ShaderNodeUVMap", uv_map="UVMap")
    mp = m.node("ShaderNodeMapping", vector_type="POINT")
    b = texture_transform_gltf_to_blender(TT)        # Blender's own conversion (its importer's)
    mp.inputs["Location"].default_value = (b["offset"][0], b["offset"][1], 0.0)
    mp.inputs["Rotation"].default_value = (0.0, 0.0, b["rotation"])
    mp.inputs["Scale"].default_value = (b["scale"][0], b["scale"][1], 1.0)
    m.link(uvn.outputs["UV"], mp.inputs["Vector"])
    m.link(mp.outputs["Vector"], t.inputs["Vector"])
    m.link(t.outputs["Color"], m.p.inputs["Base Color"])
    ob.data.materials.append(m.m)
    export("texture_transform.glb")
    # baked: uv' = T R S uv with the KHR_texture_transform matrices (rotation counter-clockwise
    # in UV space: [[cos, sin], [-sin, cos]] applied to (u, v))
    new_scene()
    c, s = math.cos(TT["rotation"]), math.sin(TT["rotation"])

    def bake(u, v):
        u, v = u * TT["scale"][0], v * TT["scale"][1]
        return (c * u + s * v + TT["offset"][0], -s * u + c * v + TT["offset"][1])

    corners = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
    uvs = [bake(0, 1), bake(1, 1), bake(1, 0), bake(0, 0)]
    ob = link_object("quad", quad_mesh("quad", corners, uvs))
    m = Mat("texture_transform_baked", roughness=0.8)
    t = m.tex(image("blocks", blocks_texture(), "sRGB"))
    m.link(t.outputs["Color"], m.p.inputs["Base Color"])
    ob.data.materials.append(m.m)
    export("texture_transform_baked.glb")


def texcoord1():
    """A quad with two UV sets; the base colour texture reads TEXCOORD_1, which is TEXCOORD_0
    transposed (u1, v1) = (v0, u0)."""
    new_scene()
    uv0 = [(0, 1), (1, 1), (1, 0), (0, 0)]
    uv1 = [(v, u) for u, v in uv0]
    corners = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
    ob = link_object("quad", quad_mesh("quad", corners, uv0, uv1))
    m = Mat("texcoord1", roughness=0.8)
    t = m.tex(image("blocks", blocks_texture(), "sRGB"), uv_map="UVMap.001")
    m.link(t.outputs["Color"], m.p.inputs["Base Color"])
    ob.data.materials.append(m.m)
    export("texcoord1.glb")


def leaf_alpha():
    """128x128 RGBA: alpha = clip(0.5 + 2.5 (1 - s)), s = sqrt((x/0.45)^2 + (y/0.25)^2) with
    (x, y) the texel centre's offset from the image centre in UV units; colour a leaf green."""
    n = 128
    c = (np.arange(n) + 0.5) / n - 0.5
    x, y = np.meshgrid(c, c)
    s = np.sqrt((x / 0.45) ** 2 + (y / 0.25) ** 2)
    alpha = np.clip(0.5 + 2.5 * (1.0 - s), 0.0, 1.0)
    rgba = np.zeros((n, n, 4), np.uint8)
    rgba[..., :3] = srgb_u8((0.12, 0.45, 0.08))
    rgba[..., 3] = np.round(alpha * 255).astype(np.uint8)
    return rgba


def bilinear_coverage(a8, cutoff, k=8):
    """Fraction of the UV square where the bilinearly interpolated (clamped) alpha >= cutoff,
    on a k-times finer grid."""
    a = a8.astype(np.float64) / 255.0
    n = a.shape[0]
    t = (np.arange(n * k) + 0.5) / (n * k) * n - 0.5
    i0 = np.clip(np.floor(t).astype(int), 0, n - 1)
    i1 = np.clip(i0 + 1, 0, n - 1)
    f = np.clip(t - np.floor(t), 0, 1)
    rows = a[i0] * (1 - f)[:, None] + a[i1] * f[:, None]
    full = rows[:, i0] * (1 - f)[None, :] + rows[:, i1] * f[None, :]
    return float(np.mean(full >= cutoff))


def alpha_assets():
    new_scene()
    rgba = leaf_alpha()
    cov = bilinear_coverage(rgba[..., 3], ALPHA_CUTOFF)
    print(f"alpha_mask_leaf: coverage of the quad at cutoff {ALPHA_CUTOFF}: {cov:.4f} (analytic ellipse "
          f"{math.pi * 0.45 * 0.25 * (1 + (0.5 - ALPHA_CUTOFF) / 2.5) ** 2:.4f}; at 0.5: "
          f"{bilinear_coverage(rgba[..., 3], 0.5):.4f})")
    ob = link_object("leaf", xy_quad("leaf", 0.0, 0.0, 1.0))
    m = Mat("leaf", roughness=0.6)
    m.m.use_backface_culling = False
    t = m.tex(image("leaf", rgba, "sRGB"))
    m.link(t.outputs["Color"], m.p.inputs["Base Color"])
    lt = m.node("ShaderNodeMath", operation="LESS_THAN")      # 1 - (alpha < cutoff): MASK
    lt.inputs[1].default_value = ALPHA_CUTOFF
    one_minus = m.node("ShaderNodeMath", operation="SUBTRACT")
    one_minus.inputs[0].default_value = 1.0
    m.link(t.outputs["Alpha"], lt.inputs[0])
    m.link(lt.outputs["Value"], one_minus.inputs[1])
    m.link(one_minus.outputs["Value"], m.p.inputs["Alpha"])
    ob.data.materials.append(m.m)
    export("alpha_mask_leaf.glb")
    # BLEND: a blue pane of alpha 0.35 at z = 0.5 in front of an opaque white quad at z = 0
    new_scene()
    back = link_object("back", xy_quad("back", 0.0, 0.0, 1.0))
    mb = Mat("white", base=(0.8, 0.8, 0.8), roughness=0.7)
    back.data.materials.append(mb.m)
    pane = link_object("pane", xy_quad("pane", 0.3, 0.3, 0.6), location=gl(0.0, 0.0, 0.5))
    mp = Mat("pane", base=(0.2, 0.4, 0.9), roughness=0.3)
    mp.set(Alpha=0.35)
    pane.data.materials.append(mp.m)
    export("alpha_blend_pane.glb")


def emissive():
    """A 2x2 quad, black base, emitting texture x (1, 0.8, 0.6) x strength 4."""
    new_scene()
    tex = np.zeros((64, 64, 3), np.uint8)
    for j in range(4):
        for i in range(4):
            tex[16 * j:16 * j + 16, 16 * i:16 * i + 16] = (255, 255, 255) if (i + j) % 2 == 0 else (0, 0, 0)
    tex[0:16, 0:16] = (255, 128, 0)          # top-left block orange
    ob = link_object("emitter", xy_quad("emitter", 0.0, 0.0, 1.0))
    m = Mat("emitter", base=(0.0, 0.0, 0.0), roughness=1.0)
    t = m.tex(image("emissive_pattern", tex, "sRGB"))
    mix = m.node("ShaderNodeMix", data_type="RGBA", blend_type="MULTIPLY")
    mix.inputs["Factor"].default_value = 1.0
    mix.inputs[7].default_value = (1.0, 0.8, 0.6, 1.0)       # B (colour)
    m.link(t.outputs["Color"], mix.inputs[6])                # A (colour)
    m.link(mix.outputs[2], m.p.inputs["Emission Color"])
    m.set(**{"Emission Strength": 4.0})
    ob.data.materials.append(m.m)
    export("emissive_texture.glb")


GRID = [(-2.25 + 0.5 * i, -1.0 + 0.5 * j, 0.0) for j in range(5) for i in range(10)]


def instanced():
    """One icosphere mesh (radius 0.2) used by 50 nodes on a 10 x 5 grid, spacing 0.5; and the
    same 50 spheres as 50 separate meshes, written by trimesh."""
    new_scene()
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=2, radius=0.2)
    src = bpy.context.active_object
    me = src.data
    me.name = "ico"
    bpy.data.objects.remove(src)
    # a colour 8-bit exact, so that trimesh (which keeps colours as 8-bit) writes the same
    m = Mat("ico", base=(178 / 255, 76 / 255, 25 / 255), roughness=0.4)
    me.materials.append(m.m)
    for k, p in enumerate(GRID):
        link_object(f"ico.{k:02d}", me, location=gl(*p))
    path = export("instanced_blender.glb")
    # copies: trimesh reads Blender's file and writes each node's geometry as its own mesh
    import logging
    import trimesh
    logging.getLogger("trimesh").setLevel(logging.ERROR)   # its optional scipy import, logged
    ico = trimesh.load(path, force="scene", process=False).geometry["ico"]
    sc = trimesh.Scene()
    for k, p in enumerate(GRID):
        sc.add_geometry(ico.copy(), geom_name=f"ico.{k:02d}", node_name=f"ico.{k:02d}",
                        transform=trimesh.transformations.translation_matrix(p))
    path = os.path.join(OUT, "instanced_copies_trimesh.glb")
    with open(path, "wb") as fh:
        fh.write(sc.export(file_type="glb", include_normals=True))
    print(f"instanced_copies_trimesh.glb: {os.path.getsize(path)} bytes")


def draco():
    """A textured torus, written with and without KHR_draco_mesh_compression."""
    new_scene()
    bpy.ops.mesh.primitive_torus_add(major_segments=48, minor_segments=16, major_radius=0.8, minor_radius=0.3,
                                     generate_uvs=True)
    ob = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    ob.name = ob.data.name = "torus"
    ob.rotation_euler = (math.radians(60), 0.0, 0.0)
    m = Mat("torus", roughness=0.5)
    t = m.tex(image("blocks", blocks_texture(), "sRGB"))
    m.link(t.outputs["Color"], m.p.inputs["Base Color"])
    ob.data.materials.append(m.m)
    export("draco_torus_uncompressed.glb")
    export("draco_torus.glb", draco=True, export_draco_mesh_compression_level=6,
           export_draco_position_quantization=14, export_draco_normal_quantization=10,
           export_draco_texcoord_quantization=12)


def extensions():
    """One sphere per material extension Blender's exporter writes from the Principled BSDF."""
    def sphere(name, m):
        ob = uv_sphere(name, 32, 16)
        ob.data.materials.append(m.m)
        return ob

    new_scene()
    m = Mat("clearcoat", base=(0.8, 0.05, 0.05), roughness=0.6)
    m.set(**{"Coat Weight": 1.0, "Coat Roughness": 0.05})
    sphere("clearcoat", m)
    export("ext_clearcoat.glb")

    new_scene()
    m = Mat("sheen", base=(0.05, 0.1, 0.4), roughness=0.8)
    m.set(**{"Sheen Weight": 1.0, "Sheen Roughness": 0.5, "Sheen Tint": (1.0, 0.9, 0.8, 1.0)})
    sphere("sheen", m)
    export("ext_sheen.glb")

    new_scene()
    m = Mat("specular", base=(0.1, 0.1, 0.1), roughness=0.2)
    m.set(**{"Specular IOR Level": 0.25, "Specular Tint": (0.2, 0.9, 0.3, 1.0)})
    sphere("specular", m)
    export("ext_specular.glb")

    new_scene()
    m = Mat("glass_volume", base=(1.0, 1.0, 1.0), roughness=0.0, ior=1.33)
    m.set(**{"Transmission Weight": 1.0})
    vol = m.node("ShaderNodeVolumeAbsorption")
    vol.inputs["Color"].default_value = (0.9, 0.5, 0.2, 1.0)
    vol.inputs["Density"].default_value = 2.0                # attenuationDistance 0.5
    m.link(vol.outputs["Volume"], m.out.inputs["Volume"])
    grp = m.node("ShaderNodeGroup")
    grp.node_tree = create_settings_group("glTF Material Output")   # Blender's own helper
    grp.inputs["Thickness"].default_value = 2.0
    sphere("glass_volume", m)
    export("ext_transmission_volume.glb")


def textured_layers():
    """Clear coat and sheen driven by textures, each on a sphere in 8 longitude sectors (u) and 4
    latitude bands (v): the coat's weight (R) alternates 1, 0 by sector, its roughness (G) is
    0.05, 0.25, 0.5, 0.8 by band; the sheen's colour (sRGB) alternates white, orange by sector,
    its roughness (alpha) is 0.2, 0.4, 0.6, 0.9 by band."""
    def sectors_bands(sector, band, channels):
        px = np.zeros((64, 64, channels), np.uint8)
        for j in range(4):
            for s in range(8):
                px[16 * j:16 * j + 16, 8 * s:8 * s + 8] = sector(s) + band(j)
        return px

    new_scene()
    coat = sectors_bands(lambda s: (255 if s % 2 == 0 else 0,), lambda j: (round(255 * [0.05, 0.25, 0.5, 0.8][j]), 0), 3)
    m = Mat("clearcoat_textured", base=(0.8, 0.05, 0.05), roughness=0.6)
    t = m.tex(image("coat_weight_rough", coat, "Non-Color"))
    sep = m.node("ShaderNodeSeparateColor")
    m.link(t.outputs["Color"], sep.inputs["Color"])
    m.link(sep.outputs["Red"], m.p.inputs["Coat Weight"])
    m.link(sep.outputs["Green"], m.p.inputs["Coat Roughness"])
    ob = uv_sphere("clearcoat_textured", 48, 24)
    ob.data.materials.append(m.m)
    export("ext_clearcoat_textured.glb")

    new_scene()
    tints = [tuple(srgb_u8((1.0, 1.0, 1.0))), tuple(srgb_u8((1.0, 0.35, 0.05)))]
    sheen = sectors_bands(lambda s: tints[s % 2], lambda j: (round(255 * [0.2, 0.4, 0.6, 0.9][j]),), 4)
    m = Mat("sheen_textured", base=(0.05, 0.1, 0.4), roughness=0.8)
    m.set(**{"Sheen Weight": 1.0})
    t = m.tex(image("sheen_color_rough", sheen, "sRGB"))
    m.link(t.outputs["Color"], m.p.inputs["Sheen Tint"])
    m.link(t.outputs["Alpha"], m.p.inputs["Sheen Roughness"])
    ob = uv_sphere("sheen_textured", 48, 24)
    ob.data.materials.append(m.m)
    export("ext_sheen_textured.glb")


def coat_normal():
    """A clear coat with its own normal map (Principled "Coat Normal" fed by a Normal Map node),
    the base's normal left alone: 16 longitude sectors of 4 columns, alternately tilting the
    coat's normal 20 degrees towards green + (the bitangent, up the image: v = 0, the north
    pole) and green -; no TANGENT written (a renderer computes MikkTSpace tangents for it)."""
    new_scene()
    px = np.zeros((64, 64, 3), np.uint8)
    for s in range(16):
        px[:, 4 * s:4 * s + 4] = tilt_rgb(0.0, S if s % 2 == 0 else -S, C)
    m = Mat("clearcoat_normal", base=(0.8, 0.05, 0.05), roughness=0.6)
    m.set(**{"Coat Weight": 1.0, "Coat Roughness": 0.05})
    t = m.tex(image("coat_normal_sectors", px, "Non-Color"))
    nm = m.node("ShaderNodeNormalMap", uv_map="UVMap")
    m.link(t.outputs["Color"], nm.inputs["Color"])
    m.link(nm.outputs["Normal"], m.p.inputs["Coat Normal"])
    ob = uv_sphere("clearcoat_normal", 32, 16)
    ob.data.materials.append(m.m)
    export("ext_clearcoat_normal.glb")


def main():
    os.makedirs(OUT, exist_ok=True)
    metal_rough_sphere()
    normal_planes()
    samplers()
    texture_transform()
    texcoord1()
    alpha_assets()
    emissive()
    instanced()
    draco()
    extensions()
    textured_layers()
    coat_normal()
    import io_scene_gltf2
    import trimesh
    print(f"Blender {bpy.app.version_string}, glTF add-on {'.'.join(map(str, io_scene_gltf2.bl_info['version']))}, "
          f"trimesh {trimesh.__version__}")


if __name__ == "__main__":
    main()
