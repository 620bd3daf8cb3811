#!/usr/bin/env python3
"""glTF assets rendered by ember and by Blender Cycles after Blender's own glTF importer.

For each asset (the feature assets in tests/data/gltf/, Khronos' DamagedHelmet in scenes/, and
optionally a second real asset named by CAN_GLB) the script renders, at W x H and SPP samples
per pixel, path length 8 (ember --max-depth 8 = Cycles max_bounces 7):
  ember   `ember render OUT/scenes/ASSET.toml -o OUT/img/ASSET_ember.exr --uniform --spp SPP
          --threads 2 --seed 0`, on a scene file this script writes: the asset as `[[meshes]]`,
          the camera, box pixel filter, `[background] type = "image"` on OUT/env.exr;
  Cycles  Blender 4.5 (PyPI bpy) imports the same file with `bpy.ops.import_scene.gltf`, the
          same camera converted to Blender's axes (glTF (x, y, z) -> Blender (x, -z, y), as the
          importer maps points), the same OUT/env.exr as World (Environment Texture into
          Background), CPU, 2 threads, no denoising, no clamping (direct or indirect), Filter
          Glossy 0, no adaptive sampling, no path guiding, caustics on, every bounce limit 7
          (transparent 16), box pixel filter of width 1 pixel, Standard view transform, film
          transparent (alpha = the asset's coverage), EXR 32-bit linear RGBA; rendered at seed 0
          and again at seed 1 (the Cycles-vs-Cycles noise floor).
The environment (OUT/env.exr, 512 x 256 equirectangular, written here) depends only on
elevation, which sidesteps the two renderers' azimuth conventions: a blue sky brightening to
the horizon, a bright ring 35 degrees up (highlights that show roughness), a dim ground.
Both renderers put the image's top row at the zenith.

Metrics, inside the asset's outline (Cycles' seed-0 alpha >= 0.999):
  ratio      mean(ember) / mean(Cycles) over the outline's pixels and RGB;
  block err  8x8-pixel blocks lying wholly inside the outline: the mean over blocks of
             |mean_ember - mean_Cycles| / mean_Cycles (block means over pixels and RGB; a block
             darker than 1% of the outline's mean is divided by that 1% instead);
  floor      the same two figures for Cycles seed 1 against Cycles seed 0;
  bg         ember's background pixels (Cycles' alpha = 0, 2 pixels from any coverage) against
             the environment's analytic radiance at the pixel centres: a check that ember sees
             the environment the right way up (1.00 expected).
Writes OUT/results.csv, OUT/results.md (a markdown table, also printed), OUT/png/ASSET.png
(ember | Cycles over the same environment | block error, 0 black to >= 50% white, blocks
outside the outline blue; both images with the same exposure, noted in results.md),
OUT/img/*.exr, OUT/logs/*.log (every command with its output), OUT/scenes/*.toml.
A render that fails (ember refusing a file) is reported in the table, not fatal.

Setup (Debian 12; bpy 4.5 needs Python 3.11 exactly and numpy < 2), and `cargo build --release`:
    python3.11 -m venv /work/venvs/bpy && /work/venvs/bpy/bin/pip install \
        bpy==4.5.15 'numpy<2' pillow OpenEXR trimesh
Command, from the repository root (with the defaults and CAN_GLB, 19 assets: 16 CPU-minutes, so
about 11 minutes on 2 free cores; 27 minutes measured while other builds kept the load at ~6):
    /work/venvs/bpy/bin/python scripts/peers/gltf_vs_cycles.py [ASSET ...]
ASSET names are those of the ASSETS table below (default: all of them whose file exists) and of
EXTRA (references for ember's own tests, e.g. texture_transform_baked, run only when named); when
both files of a reference pair (PAIRS) are run, results.md adds how alike Cycles renders them.
Environment: OUT (/tmp/peers/gltf-vs-cycles), EMBER (target/release/ember), SPP (128), SIZE
(256: the image's width and height), CAN_GLB (a second real asset, e.g. the textured drink can
white-claw-can.glb of scenes/SOURCES.md; skipped when unset), SKIP_RENDER (1: only recompute
the metrics from the images already in OUT; give the SPP and SIZE they were rendered with).
"""
import csv
import json
import math
import os
import shutil
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.normpath(os.path.join(HERE, "..", ".."))
OUT = os.environ.get("OUT", "/tmp/peers/gltf-vs-cycles")
EMBER = os.environ.get("EMBER", os.path.join(REPO, "target", "release", "ember"))
SPP = int(os.environ.get("SPP", "128"))
SIZE = int(os.environ.get("SIZE", "256"))
CAN_GLB = os.environ.get("CAN_GLB", "")
SKIP_RENDER = os.environ.get("SKIP_RENDER", "") == "1"
PATH_LENGTH = 8          # ember --max-depth 8 = Cycles max_bounces 7 (Cycles 0 = direct light only)
THREADS = 2
SEEDS = (0, 1)           # Cycles renders both; ember renders the first
BLOCK = 8
MASK_ALPHA = 0.999
ENV_W, ENV_H = 512, 256
DATA = os.path.join(REPO, "tests", "data", "gltf")

# name: (file, camera eye, look-at, vertical fov in degrees, what it shows); glTF coordinates (Y up)
SPHERE = ((0.0, 1.2, 3.6), (0.0, 0.0, 0.0), 40.0)
PLANE = ((0.0, 2.6, 2.6), (0.0, 0.0, 0.0), 45.0)
QUAD = ((0.0, 0.8, 3.1), (0.0, 0.0, 0.0), 40.0)
ASSETS = {
    "metal_rough_sphere": (os.path.join(DATA, "metal_rough_sphere.glb"), *SPHERE,
                           "base colour + metallic-roughness textures"),
    "normal_tilt20": (os.path.join(DATA, "normal_tilt20.glb"), *PLANE, "normal map, TANGENT given"),
    "normal_tilt20_mikk": (os.path.join(DATA, "normal_tilt20_mikk.glb"), *PLANE, "normal map, no TANGENT"),
    "normal_quadrants_mikk": (os.path.join(DATA, "normal_quadrants_mikk.glb"), *PLANE,
                              "normal map tilting 4 ways, no TANGENT"),
    "normal_sphere_mikk": (os.path.join(DATA, "normal_sphere_mikk.glb"), *SPHERE,
                           "normal map on a sphere, no TANGENT"),
    "samplers": (os.path.join(DATA, "samplers.glb"), (0.0, 0.0, 6.0), (0.0, 0.0, 0.0), 45.0,
                 "REPEAT, MIRRORED_REPEAT, CLAMP_TO_EDGE, mirror x clamp; UVs -1..3"),
    "texture_transform": (os.path.join(DATA, "texture_transform.glb"), *QUAD, "KHR_texture_transform"),
    "texcoord1": (os.path.join(DATA, "texcoord1.glb"), *QUAD, "base colour on TEXCOORD_1"),
    "alpha_mask_leaf": (os.path.join(DATA, "alpha_mask_leaf.glb"), *QUAD, "alphaMode MASK, cutoff 0.3"),
    "alpha_blend_pane": (os.path.join(DATA, "alpha_blend_pane.glb"), (0.4, 0.6, 3.4), (0.0, 0.0, 0.2), 40.0,
                         "alphaMode BLEND, alpha 0.35, over a white quad"),
    "emissive_texture": (os.path.join(DATA, "emissive_texture.glb"), *QUAD,
                         "emissiveTexture x factor x KHR_materials_emissive_strength"),
    "instanced_blender": (os.path.join(DATA, "instanced_blender.glb"), (0.0, 0.5, 6.0), (0.0, 0.0, 0.0), 45.0,
                          "1 mesh, 50 nodes"),
    "draco_torus": (os.path.join(DATA, "draco_torus.glb"), (0.0, 0.5, 3.5), (0.0, 0.0, 0.0), 45.0,
                    "KHR_draco_mesh_compression"),
    "ext_clearcoat": (os.path.join(DATA, "ext_clearcoat.glb"), *SPHERE, "KHR_materials_clearcoat"),
    "ext_sheen": (os.path.join(DATA, "ext_sheen.glb"), *SPHERE, "KHR_materials_sheen"),
    "ext_clearcoat_normal": (os.path.join(DATA, "ext_clearcoat_normal.glb"), *SPHERE,
                             "clear coat with its own normal map"),
    "ext_clearcoat_textured": (os.path.join(DATA, "ext_clearcoat_textured.glb"), *SPHERE,
                               "clear-coat weight and roughness textures"),
    "ext_sheen_textured": (os.path.join(DATA, "ext_sheen_textured.glb"), *SPHERE,
                           "sheen colour and roughness (alpha) textures"),
    "ext_specular": (os.path.join(DATA, "ext_specular.glb"), *SPHERE, "KHR_materials_specular"),
    "ext_transmission_volume": (os.path.join(DATA, "ext_transmission_volume.glb"), *SPHERE,
                                "KHR_materials_transmission + volume + ior"),
    "helmet": (os.path.join(REPO, "scenes", "DamagedHelmet.glb"), (1.5, 0.5, 2.9), (0.0, 0.0, -0.1), 40.0,
               "Khronos DamagedHelmet"),
    "can": (CAN_GLB, (0.12, 0.05, 0.3), (0.0, 0.006, 0.0), 35.0, "textured drink can (CAN_GLB)"),
}
# References for ember's own tests (each should look as the asset it names): not run by default.
EXTRA = {
    "normal_tilt20_geometric": (os.path.join(DATA, "normal_tilt20_geometric.glb"), *PLANE,
                                "the plane of normal_tilt20 tilted geometrically"),
    "normal_sphere": (os.path.join(DATA, "normal_sphere.glb"), *SPHERE, "normal_sphere_mikk with TANGENT"),
    "texture_transform_baked": (os.path.join(DATA, "texture_transform_baked.glb"), *QUAD,
                                "texture_transform with the transform baked into the UVs"),
    "instanced_copies_trimesh": (os.path.join(DATA, "instanced_copies_trimesh.glb"), (0.0, 0.5, 6.0),
                                 (0.0, 0.0, 0.0), 45.0, "instanced_blender as 50 meshes (trimesh)"),
    "draco_torus_uncompressed": (os.path.join(DATA, "draco_torus_uncompressed.glb"), (0.0, 0.5, 3.5),
                                 (0.0, 0.0, 0.0), 45.0, "draco_torus without Draco"),
}
ALL = {**ASSETS, **EXTRA}
# Pairs Cycles should render alike; compared (Cycles' seed-0 images) when both are run.
PAIRS = [("texture_transform", "texture_transform_baked"), ("instanced_blender", "instanced_copies_trimesh"),
         ("draco_torus", "draco_torus_uncompressed"), ("normal_sphere", "normal_sphere_mikk"),
         ("normal_tilt20", "normal_tilt20_geometric")]


# ================================================================= environment
def env_radiance(elev):
    """Linear RGB radiance for elevations `elev` (radians, numpy array): sky, ring, ground."""
    import numpy as np
    e = np.asarray(elev, dtype=np.float64)
    s = np.sqrt(np.clip(np.sin(e), 0.0, 1.0))[..., None]
    horizon, zenith = np.array([0.9, 0.9, 0.85]), np.array([0.3, 0.45, 0.8])
    sky = horizon * (1 - s) + zenith * s
    ring = np.array([6.0, 5.6, 5.0]) * np.exp(-0.5 * ((np.degrees(e) - 35.0) / 4.0) ** 2)[..., None]
    ground = np.array([0.3, 0.27, 0.24])
    t = np.clip(np.degrees(e) / 2.0 + 1.0, 0.0, 1.0)[..., None]     # -2..0 degrees: ground -> sky
    return ground * (1 - t) + (sky + ring) * t


def write_env(path):
    import numpy as np
    import OpenEXR
    rows = (np.arange(ENV_H) + 0.5) / ENV_H                             # row 0 = top = zenith
    rgb = env_radiance(math.pi / 2 - rows * math.pi)[:, None, :].repeat(ENV_W, axis=1).astype(np.float32)
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                 {"RGB": np.ascontiguousarray(rgb)}).write(path)


def camera_basis(eye, target, up=(0.0, 1.0, 0.0)):
    import numpy as np
    f = np.subtract(target, eye)
    f = f / np.linalg.norm(f)
    r = np.cross(f, up)
    r = r / np.linalg.norm(r)
    return f, r, np.cross(r, f)


def background(eye, target, fov):
    """The environment's radiance along each pixel centre's ray (pinhole, square pixels)."""
    import numpy as np
    f, r, u = camera_basis(eye, target)
    t = math.tan(math.radians(fov) / 2)
    c = (np.arange(SIZE) + 0.5) / SIZE * 2 - 1
    x, y = np.meshgrid(c * t * (SIZE / SIZE), -c * t)
    d = f[None, None] + x[..., None] * r[None, None] + y[..., None] * u[None, None]
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    return env_radiance(np.arcsin(np.clip(d[..., 1], -1, 1)))


# ================================================================= Cycles (child process)
def cycles_child(spec_json):
    spec = json.loads(spec_json)
    t0 = time.perf_counter()
    import bpy
    import addon_utils
    from mathutils import Matrix, Vector
    addon_utils.enable("io_scene_gltf2")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    bpy.ops.import_scene.gltf(filepath=spec["glb"])
    for ob in list(sc.objects):                      # the file's own cameras and lights: not ours
        if ob.type in ("CAMERA", "LIGHT"):
            bpy.data.objects.remove(ob)

    def bl(p):
        return Vector((p[0], -p[2], p[1]))

    cam_data = bpy.data.cameras.new("camera")
    cam_data.sensor_fit = "VERTICAL"
    cam_data.angle_y = math.radians(spec["fov"])
    cam_data.clip_start = 1e-3
    cam_data.clip_end = 1e5
    cam = bpy.data.objects.new("camera", cam_data)
    sc.collection.objects.link(cam)
    eye, target = bl(spec["eye"]), bl(spec["target"])
    f = (target - eye).normalized()
    r = f.cross(Vector((0.0, 0.0, 1.0))).normalized()
    u = r.cross(f)
    cam.matrix_world = Matrix.Translation(eye) @ Matrix((r, u, -f)).transposed().to_4x4()
    sc.camera = cam

    world = bpy.data.worlds.new("env")
    world.use_nodes = True
    nt = world.node_tree
    env = nt.nodes.new("ShaderNodeTexEnvironment")
    env.image = bpy.data.images.load(spec["env"])
    env.image.colorspace_settings.name = "Linear Rec.709"
    env.interpolation = "Linear"
    nt.links.new(env.outputs["Color"], nt.nodes["Background"].inputs["Color"])
    nt.nodes["Background"].inputs["Strength"].default_value = 1.0
    sc.world = world

    rs = sc.render
    rs.engine = "CYCLES"
    rs.resolution_x = rs.resolution_y = spec["size"]
    rs.resolution_percentage = 100
    rs.threads_mode = "FIXED"
    rs.threads = THREADS
    rs.film_transparent = True
    rs.use_motion_blur = False
    rs.use_compositing = False
    rs.use_sequencer = False
    c = sc.cycles
    c.device = "CPU"
    c.samples = spec["spp"]
    c.use_adaptive_sampling = False
    c.use_animated_seed = False
    b = PATH_LENGTH - 1
    c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = c.volume_bounces = b
    c.transparent_max_bounces = 16
    c.caustics_reflective = c.caustics_refractive = True
    c.blur_glossy = 0.0
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    c.pixel_filter_type = "BOX"
    c.filter_width = 1.0
    c.film_exposure = 1.0
    c.use_guiding = False
    c.use_fast_gi = False
    c.use_denoising = False
    vs = sc.view_settings
    vs.view_transform = "Standard"
    vs.look = "None"
    vs.exposure = 0.0
    vs.gamma = 1.0
    im = rs.image_settings
    im.file_format = "OPEN_EXR"
    im.color_mode = "RGBA"
    im.color_depth = "32"
    im.exr_codec = "ZIP"
    t_load = time.perf_counter() - t0
    times = {}
    for seed, out in zip(spec["seeds"], spec["outs"]):
        c.seed = seed
        t1 = time.perf_counter()
        bpy.ops.render.render(write_still=False)
        times[seed] = round(time.perf_counter() - t1, 2)
        if os.path.exists(out):
            os.remove(out)
        bpy.data.images["Render Result"].save_render(filepath=out, scene=sc)
    mats = sorted({s.material.name for o in sc.objects if o.type == "MESH" for s in o.material_slots if s.material})
    print("RESULT " + json.dumps({"blender": bpy.app.version_string, "load_s": round(t_load, 2), "render_s": times,
                                  "objects": sum(o.type == "MESH" for o in sc.objects), "materials": mats}), flush=True)


# ================================================================= running
EMBER_TOML = """\
# Written by scripts/peers/gltf_vs_cycles.py: {what}
[render]
width = {size}
height = {size}
spp = {spp}
max_depth = {depth}
filter = "box"

[camera]
position = [{eye[0]}, {eye[1]}, {eye[2]}]
look_at = [{target[0]}, {target[1]}, {target[2]}]
up = [0.0, 1.0, 0.0]
fov = {fov}

[background]
type = "image"
file = "{env}"

[[meshes]]
file = "{glb}"
"""


def log(name, argv, p, wall):
    d = os.path.join(OUT, "logs")
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name + ".log"), "w") as fh:
        fh.write(" ".join(argv) + f"\n# exit {p.returncode}, {wall:.1f} s\n" + p.stdout + p.stderr)


def render(name, spec):
    glb, eye, target, fov, what = spec
    img = os.path.join(OUT, "img")
    os.makedirs(img, exist_ok=True)
    os.makedirs(os.path.join(OUT, "scenes"), exist_ok=True)
    env = os.path.join(OUT, "env.exr")
    rec = {"asset": name, "file": glb, "what": what}
    # ember
    toml = os.path.join(OUT, "scenes", name + ".toml")
    with open(toml, "w") as fh:
        fh.write(EMBER_TOML.format(what=what, size=SIZE, spp=SPP, depth=PATH_LENGTH, eye=eye, target=target, fov=fov,
                                   env=env, glb=os.path.abspath(glb)))
    out = os.path.join(img, f"{name}_ember.exr")
    if os.path.exists(out):
        os.remove(out)
    argv = [os.path.join(OUT, "ember"), "render", toml, "-o", out, "--uniform", "--spp", str(SPP), "--max-depth", str(PATH_LENGTH),
            "--threads", str(THREADS), "--seed", str(SEEDS[0])]
    t0 = time.time()
    p = subprocess.run(argv, capture_output=True, text=True)
    rec["ember_s"] = round(time.time() - t0, 2)
    log(name + "_ember", argv, p, rec["ember_s"])
    rec["ember_cmd"] = " ".join(argv)
    warn = [ln.strip() for ln in (p.stdout + p.stderr).splitlines() if "warning" in ln.lower()]
    rec["ember_warnings"] = " / ".join(warn)[:300]
    if p.returncode != 0 or not os.path.exists(out):
        rec["ember_error"] = ((p.stderr or p.stdout).strip().splitlines() or ["no output"])[-1][:300]
    # Cycles, both seeds in one process
    outs = [os.path.join(img, f"{name}_cycles_s{s}.exr") for s in SEEDS]
    child = {"glb": os.path.abspath(glb), "eye": eye, "target": target, "fov": fov, "env": env, "size": SIZE,
             "spp": SPP, "seeds": list(SEEDS), "outs": outs}
    argv = [sys.executable, os.path.abspath(__file__), "--cycles-child", json.dumps(child)]
    t0 = time.time()
    p = subprocess.run(argv, capture_output=True, text=True)
    rec["cycles_s"] = round(time.time() - t0, 2)
    log(name + "_cycles", argv, p, rec["cycles_s"])
    res = [ln for ln in p.stdout.splitlines() if ln.startswith("RESULT ")]
    if p.returncode != 0 or not res:
        rec["cycles_error"] = ((p.stderr or p.stdout).strip().splitlines() or ["no output"])[-1][:300]
    else:
        rec["cycles"] = json.loads(res[-1][7:])
    with open(os.path.join(OUT, "runs", name + ".json"), "w") as fh:
        json.dump(rec, fh, indent=1)
    return rec


# ================================================================= metrics
def read_exr(path):
    import numpy as np
    import OpenEXR
    ch = OpenEXR.File(path).parts[0].channels
    for k in ("RGBA", "RGB"):
        if k in ch:
            a = np.asarray(ch[k].pixels, dtype=np.float64)
            break
    else:
        a = np.stack([np.asarray(ch[c].pixels, dtype=np.float64) for c in "RGBA" if c in ch], -1)
    if a.shape[-1] == 3:
        a = np.concatenate([a, np.ones(a.shape[:2] + (1,))], -1)
    return a


def block_means(img, keep):
    """Per 8x8 block: mean over pixels and RGB, for blocks whose pixels are all in `keep`."""
    h, w = (img.shape[0] // BLOCK) * BLOCK, (img.shape[1] // BLOCK) * BLOCK
    v = img[:h, :w, :3].mean(-1).reshape(h // BLOCK, BLOCK, w // BLOCK, BLOCK).mean((1, 3))
    full = keep[:h, :w].reshape(h // BLOCK, BLOCK, w // BLOCK, BLOCK).all((1, 3))
    return v, full


def compare(x, ref, mask):
    """(ratio of means, mean block relative error, block error map, blocks) of x against ref."""
    import numpy as np
    m_ref = ref[mask][:, :3].mean()
    ratio = float(x[mask][:, :3].mean() / m_ref) if m_ref > 0 else float("nan")
    bx, full = block_means(x, mask)
    br, _ = block_means(ref, mask)
    den = np.maximum(br, 0.01 * m_ref)
    err = np.abs(bx - br) / den
    return ratio, (float(err[full].mean()) if full.any() else float("nan")), np.where(full, err, np.nan), int(full.sum())


def to_rgb8(a):
    import numpy as np
    c = np.clip(np.nan_to_num(a, nan=0.0), 0.0, 1.0)
    s = np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1.0 / 2.4) - 0.055)
    return np.clip(s * 255.0 + 0.5, 0, 255).astype(np.uint8)


def side_by_side(path, ember, cyc, err_map, scale):
    import numpy as np
    from PIL import Image
    h, w = cyc.shape[:2]
    gap = np.full((h, 4, 3), 255, np.uint8)
    e8 = to_rgb8(ember[..., :3] * scale) if ember is not None else np.zeros((h, w, 3), np.uint8)
    c8 = to_rgb8(cyc[..., :3] * scale)
    em = np.kron(np.nan_to_num(err_map, nan=-1.0), np.ones((BLOCK, BLOCK)))
    e3 = np.zeros((h, w, 3), np.uint8)
    g = (np.clip(em, 0, 0.5) / 0.5 * 255).astype(np.uint8)
    e3[: em.shape[0], : em.shape[1]] = np.where((em < 0)[..., None], np.array([20, 30, 90], np.uint8), g[..., None])
    Image.fromarray(np.concatenate([e8, gap, c8, gap, e3], 1)).save(path)


def analyze(recs):
    import numpy as np
    rows = []
    os.makedirs(os.path.join(OUT, "png"), exist_ok=True)
    for rec in recs:
        name = rec["asset"]
        glb, eye, target, fov, what = ALL[name]
        row = {"asset": name, "what": what, "ember_s": rec.get("ember_s"), "cycles_s": rec.get("cycles_s"),
               "ember_error": rec.get("ember_error", ""), "cycles_error": rec.get("cycles_error", ""),
               "ember_warnings": rec.get("ember_warnings", "")}
        rows.append(row)
        paths = [os.path.join(OUT, "img", f"{name}_cycles_s{s}.exr") for s in SEEDS]
        if rec.get("cycles_error") or not all(os.path.exists(p) for p in paths):
            continue
        c0, c1 = read_exr(paths[0]), read_exr(paths[1])
        mask = c0[..., 3] >= MASK_ALPHA
        row["coverage"] = float(mask.mean())
        bg = background(eye, target, fov)
        comp = c0[..., :3] + (1 - c0[..., 3:4]) * bg       # Cycles over the same environment
        row["floor_ratio"], row["floor_block"], _, _ = compare(c1, c0, mask)
        inside = comp[mask]
        p99 = float(np.percentile(inside.max(-1), 99)) if inside.size else 1.0
        scale = min(1.0, 1.0 / p99) if p99 > 0 else 1.0
        row["png_scale"] = scale
        ember = None
        ep = os.path.join(OUT, "img", f"{name}_ember.exr")
        err_map = np.full((SIZE // BLOCK, SIZE // BLOCK), np.nan)
        if not rec.get("ember_error") and os.path.exists(ep):
            ember = read_exr(ep)
            row["ratio"], row["block"], err_map, row["blocks"] = compare(ember, c0, mask)
            # ember's background against the analytic environment, away from the asset
            cov = c0[..., 3] > 0
            near = cov.copy()
            for dy in (-2, -1, 0, 1, 2):
                for dx in (-2, -1, 0, 1, 2):
                    near |= np.roll(np.roll(cov, dy, 0), dx, 1)
            far = ~near
            if far.any():
                row["bg"] = float(ember[far][:, :3].mean() / bg[far].mean())
        side_by_side(os.path.join(OUT, "png", name + ".png"), ember, np.concatenate([comp, c0[..., 3:]], -1),
                     err_map, scale)
    return rows


def pairs(names):
    """Cycles against Cycles for each reference pair run: the two files' seed-0 images (where both
    cover the pixel), and Cycles' own floor (the second file's seed 1 against its seed 0)."""
    import numpy as np
    out = []
    for a, b in PAIRS:
        if a not in names or b not in names:
            continue
        A, B, B1 = (read_exr(os.path.join(OUT, "img", f"{n}_cycles_s{s}.exr")) for n, s in ((a, 0), (b, 0), (b, 1)))
        mask = (A[..., 3] >= MASK_ALPHA) & (B[..., 3] >= MASK_ALPHA)
        ratio, block, _, n = compare(A, B, mask)
        _, floor, _, _ = compare(B1, B, mask)
        out.append(f"| {a} / {b} | {ratio:.4f} | {block:.2%} | {floor:.2%} | {n} | "
                   f"{float(np.mean(np.abs(A[..., 3] - B[..., 3]))):.4f} |")
    if not out:
        return ""
    return ("\n## Reference pairs in Cycles\n\nThe first file's Cycles image against the second's (seed 0, where "
            "both cover the pixel); floor: the second at seed 1 against seed 0.\n\n"
            "| pair | ratio | block err | floor block | blocks | mean alpha difference |\n"
            "| --- | ---: | ---: | ---: | ---: | ---: |\n" + "\n".join(out) + "\n")


def fmt(v, spec=".3f"):
    return "n/a" if v is None or (isinstance(v, float) and math.isnan(v)) else format(v, spec)


def report(rows, wall, extra=""):
    L = []
    P = L.append
    P("# glTF assets: ember against Blender Cycles (scripts/peers/gltf_vs_cycles.py)\n")
    P(f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; {SIZE}x{SIZE}, {SPP} spp, path length {PATH_LENGTH}, "
      f"{THREADS} threads; ember `{EMBER}`; " + ("metrics recomputed from the images in OUT.\n" if SKIP_RENDER else
                                                f"whole run {wall / 60:.1f} min.\n"))
    P("Inside each asset's outline (Cycles' alpha >= 0.999): ratio = mean ember / mean Cycles; block = mean relative "
      "error of 8x8 blocks wholly inside; floor = Cycles seed 1 against seed 0; bg = ember's background against the "
      "environment (1.00 = seen the right way up).\n")
    P("| asset | what | coverage | ratio | block err | floor ratio | floor block | blocks | bg | ember s | Cycles s (2 renders) | note |")
    P("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |")
    for r in rows:
        note = ("ember failed: " + r["ember_error"]) if r["ember_error"] else (
            ("Cycles failed: " + r["cycles_error"]) if r["cycles_error"] else "")
        P(f"| {r['asset']} | {r['what']} | {fmt(r.get('coverage'), '.2f')} | {fmt(r.get('ratio'))} | "
          f"{fmt(r.get('block'), '.1%')} | {fmt(r.get('floor_ratio'))} | {fmt(r.get('floor_block'), '.1%')} | "
          f"{r.get('blocks', 'n/a')} | {fmt(r.get('bg'), '.2f')} | {fmt(r.get('ember_s'), '.1f')} | "
          f"{fmt(r.get('cycles_s'), '.1f')} | {note.replace('|', '/')} |")
    P("\nSide by side (ember | Cycles over the same environment | block error, black 0 to white >= 50%, blue outside "
      "the outline): OUT/png/ASSET.png; both images x png_scale (results.csv) so that Cycles' 99th percentile "
      "inside the outline is at most 1. ember's warnings and the commands: results.csv, logs/.\n")
    md = "\n".join(L) + "\n" + extra
    with open(os.path.join(OUT, "results.md"), "w") as fh:
        fh.write(md)
    cols = ["asset", "what", "coverage", "ratio", "block", "floor_ratio", "floor_block", "blocks", "bg", "png_scale",
            "ember_s", "cycles_s", "ember_error", "cycles_error", "ember_warnings"]
    with open(os.path.join(OUT, "results.csv"), "w", newline="") as fh:
        w = csv.DictWriter(fh, cols, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})
    print(md)


def main(names):
    t0 = time.time()
    os.makedirs(os.path.join(OUT, "runs"), exist_ok=True)
    unknown = [n for n in names if n not in ALL]
    if unknown:
        raise SystemExit(f"unknown asset(s) {unknown}; known: {', '.join(ALL)}")
    names = names or [n for n, a in ASSETS.items() if a[0] and os.path.exists(a[0])]
    missing = [n for n in names if not (ALL[n][0] and os.path.exists(ALL[n][0]))]
    if missing:
        raise SystemExit(f"missing file for {missing}: {[ALL[n][0] for n in missing]}")
    if not SKIP_RENDER:
        if not os.access(EMBER, os.X_OK):
            raise SystemExit(f"no ember binary at {EMBER} (cargo build --release, or set EMBER)")
        shutil.copy2(EMBER, os.path.join(OUT, "ember"))   # the binary measured, kept with the results
        write_env(os.path.join(OUT, "env.exr"))
    recs = []
    for n in names:
        if SKIP_RENDER:
            with open(os.path.join(OUT, "runs", n + ".json")) as fh:
                recs.append(json.load(fh))
            continue
        print(f"== {n} ({time.strftime('%H:%M:%S')})", flush=True)
        rec = render(n, ALL[n])
        print(f"   ember {rec['ember_s']} s{' FAILED: ' + rec['ember_error'] if 'ember_error' in rec else ''}; "
              f"Cycles {rec['cycles_s']} s{' FAILED: ' + rec['cycles_error'] if 'cycles_error' in rec else ''}",
              flush=True)
        recs.append(rec)
    report(analyze(recs), time.time() - t0, pairs(names))


if __name__ == "__main__":
    a = sys.argv[1:]
    if a and a[0] == "--cycles-child":
        cycles_child(a[1])
    else:
        main(a)
