#!/usr/bin/env python3
"""The broad matched suite of issue 37: ember against Mitsuba 3 (llvm_ad_rgb) on seven scenes.

Seven scenes, each written by this script into $SCRATCH/scenes twice: as an ember TOML file and as
a Mitsuba scene dict (built from one description, `scene_spec`, so both get the same numbers):
  diffuse   the Stanford bunny (scenes/bunny.obj, 69,451 triangles, flat shaded, scaled x10 and
            set on the ground) of diffuse colour (0.7, 0.55, 0.4) on a 20x20 ground quad (0.5)
            under one 1.5x1.5 rectangular area light (radiance 12) and a constant sky (0.25)
  metal     the same, the bunny GGX rough metal of alpha 0.3 (ember roughness sqrt(0.3): ember's
            alpha = roughness^2, src/material/microfacet.rs), reflectance 1
  glass     the same, the bunny smooth glass, IOR 1.5 (outside 1.0)
  mirror    the same, the bunny a perfect mirror (ember metal roughness 0, colour 1)
  scan_env  the bunny subdivided twice (flat 1-to-4 midpoint split with trimesh: the same surface,
            1,111,216 triangles, written as binary PLY) on a ground quad under scenes/sky.exr only
  textured  a UV sphere (OBJ with v/vt/vn, 128x64 segments, smooth normals) with scenes/earthmap.jpg
            (sRGB) on the ground quad, area light and constant sky as in `diffuse`
  interior  the diffuse bunny in a closed 5x3x5 room of quads (walls 0.7, floor 0.5) lit only
            through a 2x1.4 window: by the constant sky (1.0) and a 1x1 'sun' quad outside
            (radiance 600) that throws a patch of light on the floor; almost all of the light the
            camera sees has bounced (`interior_spec`)
Material and light mapping (ember -> Mitsuba), chosen to be exact where it can be:
  diffuse            -> twosided(diffuse)     (ember's opaque surfaces are two-sided)
  metal, colour 1    -> twosided(roughconductor ggx, alpha, material "none", i.e. Fresnel 1);
                        Schlick with F0 = 1 is 1 too. Differences left: ember's masking is the
                        height-correlated Smith G2, Mitsuba's the separable one (slightly darker).
  metal roughness 0  -> twosided(conductor, material "none")
  glass ior 1.5      -> dielectric int_ior 1.5, ext_ior 1.0 (Mitsuba's default outside is air 1.000277)
  texture (sRGB jpg) -> twosided(diffuse(bitmap, raw false = sRGB decoded)), bilinear
  emissive quad      -> rectangle (to_world from the quad's corner and edges, normal down) with an
                        `area` emitter of the same radiance (W/m^2/sr in both; ember's quad emits
                        from both faces, Mitsuba's from the front: the back one faces the empty sky)
                        and a black BSDF (ember's emissive material reflects nothing)
  constant sky       -> `constant` emitter of the same radiance
  image background   -> `envmap` with scale = strength and to_world = rotate_y(rotate + 180):
                        ember sees the image's centre towards -Z, Mitsuba its left edge (u = 0,
                        atan2(x, -z) = 0); checked by the block comparison in the table
  flat meshes        -> face_normals true; pixel filter box in both; camera: look-at, vertical fov
Path length: ember --max-depth 8 = Mitsuba max_depth 9 (compare_all.py's mapping: ember 1 and
Mitsuba 2 are direct light). Otherwise each renderer keeps its defaults: ember's adaptive sampling,
Sobol sampler and Russian roulette "auto"; Mitsuba's independent sampler and rr_depth 5.

Configurations (timed over ROUNDS interleaved rounds, the order rotated each round):
  ember          EMBER render (2 threads, 64 spp, seed 0), plus `EMBER info` (load + BVH build)
  ember_old      the same with EMBER_OLD (another build: its CPU time per sample against EMBER's);
                 left out when EMBER_OLD is unset
  mitsuba        Mitsuba 3.9.1 llvm_ad_rgb, 2 threads, one mi.render(spp=64, seed=0) timed in the
                 process (kernels cached on disk by the warm-up), via compare_all.py's child
References: ember REF_SPP at seed 1, Mitsuba REF_SPP/64 passes of 64 spp (seeds 1000...); each
renderer's 64 spp image is measured against its own reference (relMSE of compare_all.py, corrected
for the reference's noise by 1/(1 + 64/REF_SPP)); efficiency = 1/(relMSE x time).

It loads compare_all.py (and through it run_mitsuba.py) from PEERS_DIR (../shared/peers relative to
the repository root by default, as compare_configs.py does) and reuses its process runner (idle
wait, PSI stall and other-process CPU recording under /usr/bin/time), its Mitsuba child, image
reader and relMSE.

Setup (Debian 12, Python 3.11):
    apt-get install -y libllvm19 time
    python3 -m venv /work/venvs/mitsuba && /work/venvs/mitsuba/bin/pip install mitsuba==3.9.1 \\
        drjit pillow numpy OpenEXR trimesh
Command, from the repository root (about 30 min on 2 idle cores; REF_SPP_SCAN=256 saves ~2 min):
    SCRATCH=/tmp/peers/broad EMBER=/work/baseline/ember EMBER_OLD=/work/baseline/ember \\
        /work/venvs/mitsuba/bin/python scripts/peers/broad_suite.py setup warmup refs timing analyze
Phases: setup (scene files and meshes), warmup (untimed), refs, timing, analyze (any subset, in
order; a rerun may skip refs). Environment: SCRATCH (${TMPDIR:-/tmp}/peers/broad), EMBER
(target/release/ember), EMBER_OLD, SCENES (all seven), SIZE (512), SPP (64), REF_SPP (1024),
REF_SPP_SCAN (REF_SPP: scan_env's reference), ROUNDS (3), IDLE_MAX_S (60), PEERS_DIR, MITSUBA_PYTHON (this python).
Results: $SCRATCH/results/broad_suite.md and broad_suite.csv; side-by-side PNGs of the references
in $SCRATCH/results/img/ (ember left, Mitsuba right, same exposure, sRGB).

Child mode (used by the driver, Mitsuba venv):
    broad_suite.py --mitsuba-child SCENE SPP SEED NPASS RR_DEPTH THREADS OUT.npy
Inputs: scenes/bunny.obj, scenes/sky.exr, scenes/earthmap.jpg (credits in scenes/SOURCES.md).
"""
import csv
import importlib.util
import json
import math
import os
import re
import statistics
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
PEERS_DIR = os.environ.get("PEERS_DIR") or os.path.normpath(os.path.join(ROOT, "..", "shared", "peers"))
os.environ.setdefault("SCRATCH", os.path.join(os.environ.get("TMPDIR") or "/tmp", "peers", "broad"))
os.environ.setdefault("RESULTS_DIR", os.path.join(os.environ["SCRATCH"], "results"))
# compare_all.py falls back to $TMPDIR/peers/results when RESULTS_DIR's parent does not exist yet.
os.makedirs(os.environ["SCRATCH"], exist_ok=True)
os.environ.setdefault("IDLE_MAX_S", "60")
os.environ.setdefault("MITSUBA_PYTHON", sys.executable)
sys.path.insert(0, PEERS_DIR)  # compare_all.py imports run_mitsuba from beside itself
_spec = importlib.util.spec_from_file_location("compare_all", os.path.join(PEERS_DIR, "compare_all.py"))
ca = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(ca)

SCRATCH = ca.SCRATCH
RESULTS = ca.RESULTS
SCENE_DIR = os.path.join(SCRATCH, "scenes")
EMBER = os.environ.get("EMBER") or os.path.join(ROOT, "target", "release", "ember")
EMBER_OLD = os.environ.get("EMBER_OLD")
SIZE = int(os.environ.get("SIZE", "512"))
SPP = int(os.environ.get("SPP", "64"))
REF_SPP = int(os.environ.get("REF_SPP", "1024"))
REF_SPP_SCAN = int(os.environ.get("REF_SPP_SCAN") or REF_SPP)   # the 1M-triangle scene's
ROUNDS = int(os.environ.get("ROUNDS", "3"))
THREADS = 2
DEPTH = 8                      # ember --max-depth; Mitsuba max_depth DEPTH + 1 (set by ca.mitsuba_child)
MI_RR_DEPTH = 5                # Mitsuba's default
ALL_SCENES = ["diffuse", "metal", "glass", "mirror", "scan_env", "textured", "interior"]
SCENES = os.environ.get("SCENES", " ".join(ALL_SCENES)).split()
CONFIGS = ["ember", "mitsuba"] + (["ember_old"] if EMBER_OLD else [])
LABEL = {"ember": "ember (EMBER)", "ember_old": "ember (EMBER_OLD)",
         "mitsuba": f"Mitsuba 3.9.1 llvm_ad_rgb (rr_depth {MI_RR_DEPTH})"}
BUNNY_OBJ = os.path.join(ROOT, "scenes", "bunny.obj")
SKY_EXR = os.path.join(ROOT, "scenes", "sky.exr")
EARTH_JPG = os.path.join(ROOT, "scenes", "earthmap.jpg")

ca.SPP, ca.REF_SPP, ca.PATH_LENGTH = SPP, REF_SPP, DEPTH
ca.SCENES, ca.CONFIGS = SCENES, CONFIGS


def ref_spp(scene):
    return REF_SPP_SCAN if scene == "scan_env" else REF_SPP


# ================================================================= the scenes
def mesh_path(name):
    return os.path.join(SCENE_DIR, name)


def scene_spec(name):
    """One description per scene; `ember_toml` and `mitsuba_dict` translate it."""
    ground = {"corner": [-10.0, 0.0, -10.0], "edge1": [0.0, 0.0, 20.0], "edge2": [20.0, 0.0, 0.0],
              "material": "ground"}
    # facing down: edge1 x edge2 = x cross z = -y
    light = {"corner": [-2.25, 4.0, 0.25], "edge1": [1.5, 0.0, 0.0], "edge2": [0.0, 0.0, 1.5],
             "material": "light"}
    mats = {"ground": {"type": "diffuse", "color": [0.5, 0.5, 0.5]},
            "light": {"type": "emissive", "emission": [12.0, 12.0, 12.0]}}
    camera = {"position": [2.2, 1.6, 3.6], "look_at": [0.0, 0.7, 0.0], "up": [0.0, 1.0, 0.0], "fov": 35.0}
    sky = {"type": "constant", "color": [0.25, 0.25, 0.25]}
    obj = {"type": "diffuse", "color": [0.7, 0.55, 0.4]}
    mesh = {"file": mesh_path("bunny10.obj"), "material": "object", "flat": True}
    if name == "metal":
        obj = {"type": "metal", "color": [1.0, 1.0, 1.0], "alpha": 0.3}
    elif name == "glass":
        obj = {"type": "glass", "ior": 1.5}
    elif name == "mirror":
        obj = {"type": "metal", "color": [1.0, 1.0, 1.0], "alpha": 0.0}
    elif name == "textured":
        obj = {"type": "diffuse", "texture": EARTH_JPG}
        mesh = {"file": mesh_path("globe.obj"), "material": "object", "flat": False}
    elif name == "scan_env":
        obj = {"type": "diffuse", "color": [0.75, 0.75, 0.75]}
        mesh = {"file": mesh_path("bunny_1m.ply"), "material": "object", "flat": True}
        camera = {"position": [1.3, 1.2, 2.3], "look_at": [0.0, 0.75, 0.0], "up": [0.0, 1.0, 0.0], "fov": 40.0}
        sky = {"type": "image", "file": SKY_EXR, "strength": 1.0, "rotate": 160.0}
        del mats["light"]
        light = None
    elif name == "interior":
        return interior_spec(mesh)
    elif name != "diffuse":
        raise SystemExit(f"unknown scene {name}")
    mats["object"] = obj
    return {"camera": camera, "background": sky, "materials": mats, "meshes": [mesh],
            "quads": [ground] + ([light] if light else [])}


def interior_spec(mesh):
    """A closed room (5 x 3 x 5, walls 0.7, floor 0.5) lit only through a window in its -x wall:
    by the constant sky (1.0) and by a 1x1 "sun" quad outside (radiance 600, facing +x) whose light
    falls through the window onto the floor beside the bunny. Almost all light is indirect."""
    def quad(corner, e1, e2, material):
        return {"corner": corner, "edge1": e1, "edge2": e2, "material": material}
    W, H = 2.5, 3.0                          # half width, height
    z0, z1, y0, y1 = -1.0, 1.0, 0.8, 2.2     # the window in the wall x = -W
    quads = [quad([-W, 0.0, -W], [0.0, 0.0, 2 * W], [2 * W, 0.0, 0.0], "ground"),         # floor
             quad([-W, H, -W], [2 * W, 0.0, 0.0], [0.0, 0.0, 2 * W], "wall"),              # ceiling
             quad([-W, 0.0, -W], [2 * W, 0.0, 0.0], [0.0, H, 0.0], "wall"),                # z = -W
             quad([-W, 0.0, W], [0.0, H, 0.0], [2 * W, 0.0, 0.0], "wall"),                 # z = +W
             quad([W, 0.0, -W], [0.0, 0.0, 2 * W], [0.0, H, 0.0], "wall"),                 # x = +W
             quad([-W, 0.0, -W], [0.0, y0, 0.0], [0.0, 0.0, 2 * W], "wall"),               # x = -W: below,
             quad([-W, y1, -W], [0.0, H - y1, 0.0], [0.0, 0.0, 2 * W], "wall"),            # above,
             quad([-W, y0, -W], [0.0, y1 - y0, 0.0], [0.0, 0.0, z0 + W], "wall"),          # and beside
             quad([-W, y0, z1], [0.0, y1 - y0, 0.0], [0.0, 0.0, W - z1], "wall"),          # the window
             quad([-6.0, 4.5, -0.5], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], "light")]           # the sun, facing +x
    mats = {"ground": {"type": "diffuse", "color": [0.5, 0.5, 0.5]},
            "wall": {"type": "diffuse", "color": [0.7, 0.7, 0.7]},
            "light": {"type": "emissive", "emission": [600.0, 600.0, 600.0]},
            "object": {"type": "diffuse", "color": [0.7, 0.55, 0.4]}}
    camera = {"position": [2.1, 1.7, 2.1], "look_at": [-0.6, 0.9, -0.6], "up": [0.0, 1.0, 0.0], "fov": 60.0}
    return {"camera": camera, "background": {"type": "constant", "color": [1.0, 1.0, 1.0]}, "materials": mats,
            "meshes": [mesh], "quads": quads}


def _v(x):
    return "[" + ", ".join(repr(float(c)) for c in x) + "]"


def ember_toml(name):
    s = scene_spec(name)
    c, b = s["camera"], s["background"]
    L = [f"# {name}: written by scripts/peers/broad_suite.py (matched with its Mitsuba dict)",
         "[render]", f"width = {SIZE}", f"height = {SIZE}", f"spp = {SPP}", f"max_depth = {DEPTH}", "",
         "[camera]", f"position = {_v(c['position'])}", f"look_at = {_v(c['look_at'])}", f"up = {_v(c['up'])}",
         f"fov = {c['fov']}", "", "[background]"]
    if b["type"] == "constant":
        L += ['type = "constant"', f"color = {_v(b['color'])}"]
    else:
        L += ['type = "image"', f"file = {json.dumps(b['file'])}", f"strength = {b['strength']}",
              f"rotate = {b['rotate']}"]
    for mname, m in s["materials"].items():
        L += ["", f"[materials.{mname}]"]
        if m["type"] == "diffuse":
            L += ['type = "diffuse"'] + ([f"texture = {json.dumps(m['texture'])}"] if "texture" in m
                                         else [f"color = {_v(m['color'])}"])
        elif m["type"] == "metal":   # ember: alpha = roughness^2
            L += ['type = "metal"', f"color = {_v(m['color'])}", f"roughness = {math.sqrt(m['alpha'])!r}"]
        elif m["type"] == "glass":
            L += ['type = "glass"', f"ior = {m['ior']}"]
        elif m["type"] == "emissive":
            L += ['type = "emissive"', f"emission = {_v(m['emission'])}"]
    for me in s["meshes"]:
        L += ["", "[[meshes]]", f"file = {json.dumps(me['file'])}", f"material = \"{me['material']}\"",
              "smooth = false"]
    for q in s["quads"]:
        L += ["", "[[quads]]", f"corner = {_v(q['corner'])}", f"edge1 = {_v(q['edge1'])}",
              f"edge2 = {_v(q['edge2'])}", f"material = \"{q['material']}\""]
    return "\n".join(L) + "\n"


def mitsuba_dict(mi, name, spp):
    import numpy as np
    s = scene_spec(name)
    c, b = s["camera"], s["background"]
    rm = sys.modules.get("run_mitsuba")
    rm.W = rm.H = SIZE
    d = {"type": "scene",
         "integrator": {"type": "path", "max_depth": DEPTH + 1},   # replaced by ca.mitsuba_child (same + rr)
         # perspective, fov_axis y, look_at, hdrfilm box filter, independent sampler
         "sensor": rm.sensor(mi, c["position"], c["look_at"], c["up"], c["fov"], spp)}
    if b["type"] == "constant":
        d["sky"] = {"type": "constant", "radiance": rm.rgb(b["color"])}
    else:
        d["sky"] = {"type": "envmap", "filename": b["file"], "scale": b["strength"],
                    "to_world": mi.ScalarTransform4f().rotate([0, 1, 0], b["rotate"] + 180.0)}

    def bsdf(m):
        if m["type"] == "diffuse":
            refl = ({"type": "bitmap", "filename": m["texture"], "raw": False, "filter_type": "bilinear"}
                    if "texture" in m else rm.rgb(m["color"]))
            return {"type": "twosided", "b": {"type": "diffuse", "reflectance": refl}}
        if m["type"] == "metal":
            if m["alpha"] <= 0:
                inner = {"type": "conductor", "material": "none", "specular_reflectance": rm.rgb(m["color"])}
            else:
                inner = {"type": "roughconductor", "material": "none", "distribution": "ggx",
                         "alpha": m["alpha"], "specular_reflectance": rm.rgb(m["color"])}
            return {"type": "twosided", "b": inner}
        if m["type"] == "glass":
            return {"type": "dielectric", "int_ior": m["ior"], "ext_ior": 1.0}
        if m["type"] == "emissive":
            return {"type": "diffuse", "reflectance": rm.rgb((0, 0, 0))}
        raise SystemExit(m)

    mats = s["materials"]
    for i, me in enumerate(s["meshes"]):
        d[f"mesh{i}"] = {"type": "ply" if me["file"].endswith(".ply") else "obj", "filename": me["file"],
                         "face_normals": bool(me["flat"]), "bsdf": bsdf(mats[me["material"]])}
    for i, q in enumerate(s["quads"]):
        e1, e2, c0 = (np.array(q[k], dtype=float) for k in ("edge1", "edge2", "corner"))
        n = np.cross(e1, e2)
        n /= np.linalg.norm(n)
        ctr = c0 + 0.5 * (e1 + e2)
        # rectangle: [-1,1]^2 in local xy, normal +z -> corner + [0,1]^2 of (edge1, edge2), normal edge1 x edge2
        M = [[e1[0] / 2, e2[0] / 2, n[0], ctr[0]], [e1[1] / 2, e2[1] / 2, n[1], ctr[1]],
             [e1[2] / 2, e2[2] / 2, n[2], ctr[2]], [0, 0, 0, 1]]
        m = mats[q["material"]]
        sh = {"type": "rectangle", "to_world": mi.ScalarTransform4f(M), "bsdf": bsdf(m)}
        if m["type"] == "emissive":
            sh["emitter"] = {"type": "area", "radiance": rm.rgb(m["emission"])}
        d[f"quad{i}"] = sh
    return d


def make_meshes():
    """bunny10.obj (scenes/bunny.obj x10 on y = 0), bunny_1m.ply (it, subdivided twice), globe.obj."""
    import numpy as np
    os.makedirs(SCENE_DIR, exist_ok=True)
    vs, fs = [], []
    for line in open(BUNNY_OBJ):
        t = line.split()
        if t and t[0] == "v":
            vs.append([float(x) for x in t[1:4]])
        elif t and t[0] == "f":
            fs.append([int(x.split("/")[0]) for x in t[1:4]])
    v = np.array(vs) * 10.0
    f = np.array(fs) - 1
    used = np.unique(f)
    lo, hi = v[used].min(0), v[used].max(0)
    v -= [(lo[0] + hi[0]) / 2, lo[1], (lo[2] + hi[2]) / 2]       # centred in x, z; resting on y = 0
    p = mesh_path("bunny10.obj")
    if not os.path.exists(p):
        with open(p + ".tmp", "w") as fh:
            fh.write("# scenes/bunny.obj (Stanford Bunny, Stanford Computer Graphics Laboratory) x10, on y = 0\n")
            fh.write("".join("v %.7g %.7g %.7g\n" % tuple(x) for x in v))
            fh.write("".join("f %d %d %d\n" % tuple(x) for x in f + 1))
        os.replace(p + ".tmp", p)
    p = mesh_path("bunny_1m.ply")
    if not os.path.exists(p):
        import trimesh
        vv, ff = v, f
        for _ in range(2):   # flat 1-to-4 split: the same surface, 4x the triangles
            vv, ff = trimesh.remesh.subdivide(vv, ff)
        vv, ff = np.asarray(vv, "<f4"), np.asarray(ff, "<i4")
        with open(p + ".tmp", "wb") as fh:
            fh.write((f"ply\nformat binary_little_endian 1.0\ncomment scenes/bunny.obj x10, subdivided twice "
                      f"(trimesh.remesh.subdivide)\nelement vertex {len(vv)}\nproperty float x\nproperty float y\n"
                      f"property float z\nelement face {len(ff)}\nproperty list uchar int vertex_indices\n"
                      "end_header\n").encode())
            rec = np.zeros(len(ff), dtype=[("n", "u1"), ("i", "<i4", 3)])
            rec["n"], rec["i"] = 3, ff
            fh.write(vv.tobytes())
            fh.write(rec.tobytes())
        os.replace(p + ".tmp", p)
    p = mesh_path("globe.obj")
    if not os.path.exists(p):
        nu, nv, r, cy = 128, 64, 0.8, 0.8
        L = ["# UV sphere, radius 0.8 at (0, 0.8, 0); u = 1/2 + atan2(x, z)/2pi, v from the south pole (0) to the north (1)"]
        for j in range(nv + 1):
            th = math.pi * j / nv                          # from the north pole
            for i in range(nu + 1):
                ph = math.pi * (2 * i / nu - 1)            # atan2(x, z): u = 1/2 faces +Z, as ember's spheres
                n = (math.sin(th) * math.sin(ph), math.cos(th), math.sin(th) * math.cos(ph))
                L.append("v %.7g %.7g %.7g" % (r * n[0], cy + r * n[1], r * n[2]))
                L.append("vn %.7g %.7g %.7g" % n)
                L.append("vt %.7g %.7g" % (i / nu, 1 - j / nv))
        idx = lambda i, j: j * (nu + 1) + i + 1
        for j in range(nv):
            for i in range(nu):
                a, b_, c_, d_ = idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)
                # counter-clockwise seen from outside
                if j > 0:
                    L.append("f %d/%d/%d %d/%d/%d %d/%d/%d" % (a, a, a, d_, d_, d_, b_, b_, b_))
                if j < nv - 1:
                    L.append("f %d/%d/%d %d/%d/%d %d/%d/%d" % (b_, b_, b_, d_, d_, d_, c_, c_, c_))
        open(p, "w").write("\n".join(L) + "\n")


def toml_path(scene):
    return os.path.join(SCENE_DIR, f"{scene}.toml")


# ================================================================= commands (compare_all.run calls this)
def command(cfg, scene, spp, seed, threads, out, extra=()):
    env = dict(os.environ)
    if cfg in ("ember", "ember_old"):
        exe = EMBER if cfg == "ember" else EMBER_OLD
        argv = [exe, "render", toml_path(scene), "--width", str(SIZE), "--height", str(SIZE), "--spp", str(spp),
                "--max-depth", str(DEPTH), "--threads", str(threads), "--seed", str(seed), "-o", out] + list(extra)
    elif cfg in ("ember_info", "ember_old_info"):
        argv = [EMBER if cfg == "ember_info" else EMBER_OLD, "info", toml_path(scene)]
    elif cfg == "mitsuba":
        npass = max(1, spp // SPP) if spp > SPP else 1
        argv = [ca.MI_PY, os.path.abspath(__file__), "--mitsuba-child", scene, str(spp // npass), str(seed),
                str(npass), str(MI_RR_DEPTH), str(threads), out]
        env["HOME"] = os.path.join(SCRATCH, "mitsuba_home")    # Dr.Jit's on-disk kernel cache ($HOME/.drjit)
        os.makedirs(env["HOME"], exist_ok=True)
        env.setdefault("DRJIT_LIBLLVM_PATH", ca.LLVM19)
    else:
        raise SystemExit(cfg)
    return argv, env


ca.command = command


def run(phase, cfg, scene, spp, seed=0, tag="", rnd=None, order=None, timed=True):
    return ca.run(phase, cfg, scene, spp, seed=seed, threads=THREADS, tag=tag, rnd=rnd, order=order, timed=timed)


def log_text(r):
    p = os.path.join(SCRATCH, "logs", f"{r['phase']}_{r['cfg']}_{r['scene']}_{r['spp']}_{r['seed']}_"
                                      f"{r['threads']}_{r['tag']}.log")
    return open(p).read() if os.path.exists(p) else ""


def ember_stats(text):
    """'rendered 512x512 at 64 spp [on average (adaptive ...)] in T s: ... (N rays, ...)' and
    `ember info`'s 'bvh build: X ms'."""
    out = {}
    m = re.search(r"rendered (\d+)x(\d+) at ([\d.]+) spp(?: on average)?.*? in ([\d.]+) s.*?\((\d+) rays", text)
    if m:
        out.update(mean_spp=float(m.group(3)), render_s=float(m.group(4)), rays=int(m.group(5)))
    m = re.search(r"^bvh build:\s+([\d.]+) ms", text, re.M)
    if m:
        out["bvh_ms"] = float(m.group(1))
    m = re.search(r"^kernel: .*$", text, re.M)
    if m:
        out["kernel"] = m.group(0)
    return out


# ================================================================= phases
def phase_setup():
    os.makedirs(SCENE_DIR, exist_ok=True)
    make_meshes()
    for s in SCENES:
        open(toml_path(s), "w").write(ember_toml(s))
    for exe in [EMBER] + ([EMBER_OLD] if EMBER_OLD else []):
        if not os.path.exists(exe):
            raise SystemExit(f"{exe} missing")


def phase_warmup():
    # Untimed: the page cache, and Dr.Jit's on-disk kernel cache for every scene at the timed spp.
    for scene in SCENES:
        run("warmup", "mitsuba", scene, SPP, tag="warm", timed=False)
        for cfg in ("ember", "ember_old"):
            if cfg in CONFIGS:
                run("warmup", cfg, scene, 4, tag="warm", timed=False)


def phase_refs():
    for scene in SCENES:
        run("ref", "ember", scene, ref_spp(scene), seed=1, tag="ref")
        run("ref", "mitsuba", scene, ref_spp(scene), seed=ca.MI_REF_SEED, tag="ref")


def phase_timing():
    ca.wait_load(max_s=120)
    per_scene = ["ember", "ember_info", "mitsuba"] + (["ember_old", "ember_old_info"] if EMBER_OLD else [])
    jobs = [(s, c) for s in SCENES for c in per_scene]
    for r in range(ROUNDS):
        k = (r * len(jobs)) // ROUNDS           # rotate the order each round, as compare_all.py does
        for i, (scene, cfg) in enumerate(jobs[k:] + jobs[:k]):
            run("timing", cfg, scene, SPP, tag=f"r{r}", rnd=r, order=i)


# ================================================================= analysis
def to_srgb8(a, scale):
    import numpy as np
    x = np.clip(a * scale, 0, 1)
    x = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    return (x * 255 + 0.5).astype(np.uint8)


def block_diff(a, b, n=8):
    """The largest |mean_a - mean_b| / mean_b over n x n blocks of the image (blocks darker than 10% of
    the image mean use that 10%): a mirrored or turned environment or texture shows here."""
    import numpy as np
    h, w = a.shape[:2]
    A = a[: h // n * n, : w // n * n].reshape(n, h // n, n, w // n, 3).mean((1, 3, 4))
    B = b[: h // n * n, : w // n * n].reshape(n, h // n, n, w // n, 3).mean((1, 3, 4))
    return float((np.abs(A - B) / np.maximum(B, 0.1 * b.mean())).max())


def phase_analyze():
    import numpy as np
    runs = [r for r in map(json.loads, open(ca.RUNS)) if r["scene"] in SCENES]
    latest = {}
    for r in runs:
        latest[(r["phase"], r["cfg"], r["scene"], r["spp"], r["seed"], r["threads"], r["tag"])] = r
    runs = sorted(latest.values(), key=lambda r: r["start"])
    for r in runs:
        if r["cfg"].startswith("ember"):
            r.update(ember_stats(log_text(r)))
    med = ca.med
    rows, notes = [], []
    os.makedirs(os.path.join(RESULTS, "img"), exist_ok=True)
    for scene in SCENES:
        T = {cfg: [r for r in runs if r["phase"] == "timing" and r["scene"] == scene and r["cfg"] == cfg]
             for cfg in ("ember", "ember_old", "mitsuba", "ember_info", "ember_old_info")}
        refs = {r["cfg"]: r for r in runs if r["phase"] == "ref" and r["scene"] == scene}
        if not T["ember"] or not T["mitsuba"]:
            continue
        row = {"scene": scene, "size": SIZE, "spp": SPP, "rounds": len(T["ember"])}
        e_render = med([r.get("render_s") for r in T["ember"]])
        e_wall = med([r["wall_s"] for r in T["ember"]])
        m_render = med([r["render_s"] for r in T["mitsuba"]])
        m_wall = med([r["wall_s"] for r in T["mitsuba"]])
        row.update(ember_render_s=e_render, ember_process_s=e_wall, mitsuba_render_s=m_render,
                   mitsuba_process_s=m_wall,
                   ember_info_s=med([r["wall_s"] for r in T["ember_info"]]),
                   ember_bvh_ms=med([r.get("bvh_ms") for r in T["ember_info"]]),
                   ember_mean_spp=med([r.get("mean_spp") for r in T["ember"]]),
                   ember_kernel=(T["ember"][0].get("kernel") or ""))
        row["ember_nonrender_s"] = e_wall - e_render if e_render else None
        # images: the round-0 64 spp image (deterministic per seed) against each renderer's own reference
        img = {cfg: ca.read_image(min(T[cfg], key=lambda r: r["round"])["image"]) for cfg in ("ember", "mitsuba")}
        for cfg in ("ember", "mitsuba"):
            row[f"{cfg}_mean"] = float(img[cfg].mean())
        if "ember" in refs and "mitsuba" in refs:
            ref = {cfg: ca.read_image(refs[cfg]["image"]) for cfg in ("ember", "mitsuba")}
            for cfg in ("ember", "mitsuba"):
                n = refs[cfg]["spp"]
                row[f"{cfg}_ref_spp"] = n
                row[f"{cfg}_ref_mean"] = float(ref[cfg].mean())
                row[f"{cfg}_relmse"] = ca.relmse(img[cfg], ref[cfg]) / (1 + SPP / n)
            row["ref_mean_ratio"] = row["ember_ref_mean"] / row["mitsuba_ref_mean"]
            row["ref_channel_ratio"] = [float(x) for x in ref["ember"].mean((0, 1)) / ref["mitsuba"].mean((0, 1))]
            row["ref_block_diff"] = block_diff(ref["ember"], ref["mitsuba"])
            row["ref_relmse_cross"] = ca.relmse(ref["ember"], ref["mitsuba"])
            # against the other renderer's reference (independent samples by construction): ~ own relMSE +
            # the other reference's noise if the own-reference figures are not flattered by correlated seeds
            row["ember_relmse_vs_mitsuba_ref"] = ca.relmse(img["ember"], ref["mitsuba"])
            row["mitsuba_relmse_vs_ember_ref"] = ca.relmse(img["mitsuba"], ref["ember"])
            row["eff_ratio"] = (row["mitsuba_relmse"] * m_render) / (row["ember_relmse"] * e_render)
            row["eff_ratio_process"] = (row["mitsuba_relmse"] * m_wall) / (row["ember_relmse"] * e_wall)
            from PIL import Image
            sc = 0.5 / max(1e-6, float(np.median(ref["mitsuba"])))
            Image.fromarray(np.concatenate([to_srgb8(ref["ember"], sc), to_srgb8(ref["mitsuba"], sc)], 1)).save(
                os.path.join(RESULTS, "img", f"{scene}_ember_vs_mitsuba.png"))
        # CPU per sample: process CPU less that of `ember info` (load + BVH build) of the same binary
        for cfg, info in (("ember", "ember_info"), ("ember_old", "ember_old_info")):
            if T[cfg] and T[info]:
                load_cpu = med([r["cpu_s"] for r in T[info]])
                per = [(r["cpu_s"] - load_cpu) / (SIZE * SIZE * r["mean_spp"]) for r in T[cfg] if r.get("mean_spp")]
                row[f"{cfg}_cpu_us_per_sample"] = med(per) * 1e6 if per else None
        if row.get("ember_old_cpu_us_per_sample"):
            row["cpu_per_sample_vs_old"] = row["ember_cpu_us_per_sample"] / row["ember_old_cpu_us_per_sample"]
        stalls = [r["psi_stall_s"] for cfgs in T.values() for r in cfgs]
        row["psi_stall_max_s"], row["psi_stall_sum_s"] = max(stalls), sum(stalls)
        row["other_cpu_max_s"] = max(r["other_cpu_s"] for cfgs in T.values() for r in cfgs)
        row["ember_render_all"] = [r.get("render_s") for r in sorted(T["ember"], key=lambda r: r["round"])]
        row["mitsuba_render_all"] = [r["render_s"] for r in sorted(T["mitsuba"], key=lambda r: r["round"])]
        rows.append(row)
    rows.sort(key=lambda r: (r.get("eff_ratio") is None, r.get("eff_ratio") or 0))   # ember's losses first
    write_outputs(rows, runs)


def write_outputs(rows, runs):
    f, g = ca.f, ca.g
    os.makedirs(RESULTS, exist_ok=True)
    cols = ["scene", "size", "spp", "rounds", "ember_render_s", "mitsuba_render_s", "ember_process_s",
            "mitsuba_process_s", "ember_info_s", "ember_bvh_ms", "ember_nonrender_s", "ember_mean_spp",
            "ember_relmse", "mitsuba_relmse", "eff_ratio", "eff_ratio_process", "ember_mean", "mitsuba_mean",
            "ember_ref_spp", "mitsuba_ref_spp", "ember_ref_mean", "mitsuba_ref_mean", "ref_mean_ratio",
            "ref_channel_ratio", "ref_block_diff", "ref_relmse_cross", "ember_relmse_vs_mitsuba_ref",
            "mitsuba_relmse_vs_ember_ref", "ember_cpu_us_per_sample",
            "ember_old_cpu_us_per_sample", "cpu_per_sample_vs_old", "psi_stall_max_s", "psi_stall_sum_s",
            "other_cpu_max_s", "ember_render_all", "mitsuba_render_all", "ember_kernel"]
    with open(os.path.join(RESULTS, "broad_suite.csv"), "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        for r in rows:
            w.writerow([(f"{r[c]:.6g}" if isinstance(r.get(c), float) else
                         (" ".join(f"{x:.4g}" if isinstance(x, float) else str(x) for x in r[c])
                          if isinstance(r.get(c), list) else r.get(c, ""))) for c in cols])
    L = []
    P = L.append
    P("# ember against Mitsuba 3 on the broad matched suite (issue 37)\n")
    P(f"Generated by `scripts/peers/broad_suite.py` on {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}. "
      f"{SIZE}x{SIZE}, {THREADS} threads, {SPP} spp, ember --max-depth {DEPTH} = Mitsuba max_depth {DEPTH + 1}; "
      f"ember {EMBER} (defaults: adaptive sampling, Sobol, rr auto), EMBER_OLD {EMBER_OLD or 'unset'}; "
      f"Mitsuba llvm_ad_rgb, rr_depth {MI_RR_DEPTH}, independent sampler. Medians of {ROUNDS} interleaved rounds. "
      "Rows sorted by efficiency ratio, ember's losses first.\n")
    P("- **time**: ember's own 'rendered ... in T s' and Mitsuba's `mi.render` call (both render only); "
      "'load+BVH' is the wall time of `ember info SCENE` (process: scene and mesh load, BVH build, light "
      "setup), with its 'bvh build' line in brackets.")
    P("- **relMSE**: each renderer's 64 spp image (seed 0) against its own reference (other seeds), "
      "mean over pixels and RGB of (x-r)^2/(r^2+0.01), x 1/(1+64/N). **eff** = (relMSE x time of Mitsuba) / "
      "(relMSE x time of ember): above 1 ember is more efficient; 'proc' uses both process wall times.")
    P("- **means**: mean linear pixel value of the references (64 spp images in the CSV); 'blocks' is the largest "
      "relative difference of 8x8 block means between the references (orientation check).")
    P("- **CPU/sample vs old**: (render process CPU - `ember info` CPU) / samples taken, EMBER over EMBER_OLD.\n")
    P("| scene | ember s | Mitsuba s | eff ember/Mitsuba (proc) | relMSE ember | relMSE Mitsuba | mean ember | mean Mitsuba | ratio | blocks | ember load+BVH s (bvh ms) | ember process s | Mitsuba process s | ember spp | CPU/sample vs old | PSI stall max s |")
    P("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for r in rows:
        P(f"| {r['scene']} | {f(r['ember_render_s'], 2)} | {f(r['mitsuba_render_s'], 2)} | "
          f"{f(r.get('eff_ratio'), 2)} ({f(r.get('eff_ratio_process'), 2)}) | {g(r.get('ember_relmse'))} | "
          f"{g(r.get('mitsuba_relmse'))} | {f(r.get('ember_ref_mean'), 4)} | {f(r.get('mitsuba_ref_mean'), 4)} | "
          f"{f(r.get('ref_mean_ratio'), 3)} | {f(r.get('ref_block_diff'), 2)} | {f(r['ember_info_s'], 2)} "
          f"({f(r['ember_bvh_ms'], 0)}) | {f(r['ember_process_s'], 2)} | {f(r['mitsuba_process_s'], 2)} | "
          f"{f(r['ember_mean_spp'], 1)} | {f(r.get('cpu_per_sample_vs_old'), 3)} | {f(r['psi_stall_max_s'], 2)} |")
    P("\nPer round (render s): " + "; ".join(
        f"{r['scene']}: ember {', '.join(f(x, 2) for x in r['ember_render_all'])}, Mitsuba "
        f"{', '.join(f(x, 2) for x in r['mitsuba_render_all'])}" for r in rows) + ".\n")
    P("Per channel reference mean ratios (ember/Mitsuba, RGB): " + "; ".join(
        f"{r['scene']} {' '.join(f(x, 3) for x in r.get('ref_channel_ratio', []))}" for r in rows) + ".\n")
    P("Cross-check, raw relMSE of each 64 spp image against the *other* renderer's reference (ember / Mitsuba): "
      + "; ".join(f"{r['scene']} {g(r.get('ember_relmse_vs_mitsuba_ref'))} / {g(r.get('mitsuba_relmse_vs_ember_ref'))}"
                  for r in rows) + "; the references differ by " + ", ".join(
        f"{r['scene']} {g(r.get('ref_relmse_cross'))}" for r in rows) + ".\n")
    P("ember kernels: " + "; ".join(f"{r['scene']}: `{r['ember_kernel']}`" for r in rows) + "\n")
    timed = [r for r in runs if r["phase"] in ("timing", "ref")]
    dist = [r for r in timed if r["psi_stall_s"] > 0.1]
    P(f"PSI CPU stall: {len(dist)} of {len(timed)} timed processes above 0.1 s; the largest "
      f"{max([r['psi_stall_s'] for r in timed] or [0]):.2f} s, in total {sum(r['psi_stall_s'] for r in timed):.2f} s; "
      f"other-process CPU at most {max([r['other_cpu_s'] for r in timed] or [0]):.2f} s per run.")
    for r in dist:
        P(f"  - {r['phase']} r{r['round']} {r['cfg']} {r['scene']}: stall {r['psi_stall_s']} s, other CPU "
          f"{r['other_cpu_s']} s, wall {r['wall_s']} s")
    P("\nCommands (round 0):\n")
    for r in [r for r in runs if r["phase"] in ("timing", "ref") and r["round"] in (0, None)]:
        P(f"- {r['phase']} {r['scene']} {r['cfg']} {r['spp']} spp: `{r['cmd']}`")
    open(os.path.join(RESULTS, "broad_suite.md"), "w").write("\n".join(L) + "\n")
    print("\n".join(L))


# ================================================================= main
def main(phases):
    known = {"setup": phase_setup, "warmup": phase_warmup, "refs": phase_refs, "timing": phase_timing,
             "analyze": phase_analyze}
    if set(phases) - set(known):
        raise SystemExit(f"unknown phase(s) {sorted(set(phases) - set(known))}; phases: {list(known)}")
    os.makedirs(SCRATCH, exist_ok=True)
    for p in phases:
        print(f"== {p} ({time.strftime('%H:%M:%S')})", flush=True)
        known[p]()


if __name__ == "__main__":
    a = sys.argv[1:]
    if a and a[0] == "--mitsuba-child":
        import run_mitsuba as rm
        rm.scene_dict = mitsuba_dict        # compare_all's child builds the scene through this
        s, spp, seed, npass, rr, thr, out = a[1:8]
        ca.mitsuba_child(s, int(spp), int(seed), int(npass), int(rr), int(thr), out)
    else:
        main(a or ["setup", "warmup", "refs", "timing", "analyze"])
