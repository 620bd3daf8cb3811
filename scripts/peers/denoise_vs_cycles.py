#!/usr/bin/env python3
"""Denoised renders at equal time: ember + Open Image Denoise against Blender Cycles + its own OIDN.

Two matched scenes, 512x512, path length 8 (ember --max-depth 8 = Cycles max_bounces 7), 2 threads:
  cornell  Embree's Cornell box (scenes/cornell_box.obj, point light): ember scenes/cornell.toml
  teapot   scenes/teapot.obj, diffuse Kd 1, flat, black background, point light (5,10,8) I=400,
           camera from (0.2,4.5,9) to (0.2,1.3,0), fov 40; ember reads a TOML this script writes
For each scene it renders, noisy and denoised:
  ember   `ember render ... [--denoise]` (OIDN 2.5.1: albedo + normal, prefiltered, high quality)
          at EMBER_SPPS; time = the whole process (/usr/bin/time), plus ember's own "rendered in"
          and "denoised in" figures;
  Cycles  Blender 4.5 (PyPI bpy), CPU, with its OIDN (2.3.3 in that wheel: albedo + normal passes,
          prefilter ACCURATE, quality HIGH, CPU) at CYCLES_SPPS; time = the render call (as
          shared/peers/run_cycles.py times it), plus the process time.
Every timed render runs ROUNDS times (rounds alternate ember and Cycles jobs, and which goes
first). Before each one the script waits (up to IDLE_MAX_S) for the CPUs to be >= 90% idle and
records the PSI CPU stall (/proc/pressure/cpu "some") and other processes' CPU time; a run is
"clean" if the stall is <= max(0.5 s, 5% of its wall time). Phase `retime` runs again (when idle,
waiting up to RETIME_IDLE_MAX_S) each configuration with fewer than ROUNDS clean runs, up to
RETIME_MAX more times; medians are over the clean runs.
References (untimed): each renderer's own at REF_SPP, seed 1 (the timed renders use seed 0).
Metrics of each image against the renderer's own reference, against ember's, and (results.csv) against
the mean of both references:
  relMSE = mean over pixels and RGB of (x-r)^2/(r^2+0.01), on linear values; "corrected" subtracts
           the reference's own noise, estimated from the highest-spp noisy render (its relMSE
           m at s spp is v/s + v/N, so the reference contributes m/(N/s+1));
  FLIP   = mean of NVIDIA's LDR FLIP map (flip-evaluator) at 67 pixels per degree of the 8-bit sRGB
           images, made as ember's Film::to_rgb8 makes them (clamp to [0,1], sRGB encode, *255+0.5,
           truncate): the figure `ember converge` reports.
The equal-time reading interpolates error and spp linearly in log(time) - log(error) between the
two renders of the other renderer whose times bracket the given one.

Setup (Debian 12; bpy 4.5 needs Python 3.11 exactly and numpy < 2), and a release build of ember
with OIDN installed (scripts/install-deps.sh):
    python3 -m venv /tmp/peers/cycles-venv && /tmp/peers/cycles-venv/bin/pip install \
        bpy==4.5.15 pillow OpenEXR 'numpy<2' flip-evaluator
Command, from the repository root (~45 min on 2 idle cores):
    /tmp/peers/cycles-venv/bin/python scripts/peers/denoise_vs_cycles.py [refs] [timing] [retime] [analyze]
Environment: OUT (/tmp/peers/dn/vs-cycles), EMBER (target/release/ember; copied into OUT first, so a
rebuild during the run does not change it), ROUNDS (3), REF_SPP (1024), EMBER_SPPS ("4 16 64"),
CYCLES_SPPS ("2 4 8 16 64"), IDLE_MAX_S (20), RETIME_IDLE_MAX_S (120), RETIME_MAX (3). Writes OUT/runs.jsonl (every process),
OUT/results.csv and OUT/results.md.

The Cycles scene construction is copied from shared/peers/run_cycles.py (build_scene), with the
Cornell box's camera and light written out from Embree's cornell_box.ecs.
"""
import glob
import json
import math
import os
import re
import shutil
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.normpath(os.path.join(HERE, "..", ".."))
OUT = os.environ.get("OUT", "/tmp/peers/dn/vs-cycles")
EMBER_SRC = os.environ.get("EMBER", os.path.join(REPO, "target", "release", "ember"))
EMBER = os.path.join(OUT, "ember")
RUNS = os.path.join(OUT, "runs.jsonl")

W = H = 512
PATH_LENGTH = 8          # ember --max-depth 8 = Cycles max_bounces 7 (Cycles 0 = direct light only)
THREADS = 2
ROUNDS = int(os.environ.get("ROUNDS", "3"))
REF_SPP = int(os.environ.get("REF_SPP", "1024"))
EMBER_SPPS = [int(x) for x in os.environ.get("EMBER_SPPS", "4 16 64").split()]
CYCLES_SPPS = [int(x) for x in os.environ.get("CYCLES_SPPS", "2 4 8 16 64").split()]
IDLE_MAX_S = float(os.environ.get("IDLE_MAX_S", "20"))
SEED, REF_SEED = 0, 1
SCENES = ["cornell", "teapot"]
REL_EPS = 1e-2
FLIP_PPD = 67.0

CORNELL_OBJ = os.path.join(REPO, "scenes", "cornell_box.obj")   # Embree's, byte for byte
TEAPOT_OBJ = os.path.join(REPO, "scenes", "teapot.obj")
EMBER_CORNELL = os.path.join(REPO, "scenes", "cornell.toml")
EMBER_TEAPOT = os.path.join(OUT, "teapot_matched.toml")
TEAPOT_TOML = """\
# Teapot matched scene, written by scripts/peers/denoise_vs_cycles.py: Kd 1 diffuse, flat face
# normals, black background (the default), one point light.
[render]
width = 512
height = 512
spp = 64
max_depth = 8

[camera]
position = [0.2, 4.5, 9.0]
look_at = [0.2, 1.3, 0.0]
up = [0.0, 1.0, 0.0]
fov = 40

[materials.white]
type = "diffuse"
color = [1.0, 1.0, 1.0]

[[meshes]]
file = "%s"
material = "white"
smooth = false

[[lights]]
type = "point"
position = [5.0, 10.0, 8.0]
intensity = [400.0, 400.0, 400.0]
"""


# ================================================================= Cycles scene (child process)
def parse_mtl(path):
    kd, cur = {}, None
    for line in open(path):
        t = line.split()
        if not t:
            continue
        if t[0] == "newmtl":
            cur = t[1]
            kd[cur] = (1.0, 1.0, 1.0)  # Embree's OBJ default Kd is 1
        elif t[0] == "Kd" and cur:
            kd[cur] = tuple(float(x) for x in t[1:4])
    return kd


def scene_params(name):
    """(obj path, {mtl: Kd}, default Kd, camera (from, to, up, fov_y_deg), light (pos, I W/sr))"""
    if name == "cornell":
        # cornell_box.ecs: -i cornell_box.obj -pointlight 213 300 227 100000 100000 100000
        #                  -vp 278 273 -800 -vi 278 273 0 -vu 0 1 0 -fov 37
        kd = {}
        for line in open(CORNELL_OBJ):
            if line.startswith("mtllib"):
                kd.update(parse_mtl(os.path.join(os.path.dirname(CORNELL_OBJ), line.split()[1])))
        return (CORNELL_OBJ, kd, (1.0, 1.0, 1.0),
                ([278.0, 273.0, -800.0], [278.0, 273.0, 0.0], [0.0, 1.0, 0.0], 37.0),
                ([213.0, 300.0, 227.0], 100000.0))
    if name == "teapot":
        return (TEAPOT_OBJ, {}, (1.0, 1.0, 1.0),
                ([0.2, 4.5, 9.0], [0.2, 1.3, 0.0], [0.0, 1.0, 0.0], 40.0),
                ([5.0, 10.0, 8.0], 400.0))
    raise SystemExit(f"unknown scene {name}")


def build_scene(bpy, name, spp, threads, max_bounces, seed, denoise):
    """As shared/peers/run_cycles.py build_scene, plus Cycles' OIDN when `denoise`."""
    from mathutils import Matrix, Vector
    obj, kd, kd_default, (vp, vi, vu, fov), (lpos, intensity) = scene_params(name)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    # OBJ importer without axis conversion (forward Y / up Z is the identity)
    bpy.ops.wm.obj_import(filepath=obj, forward_axis='Y', up_axis='Z')
    mats = {}

    def diffuse(key, rgb):
        if key not in mats:
            m = bpy.data.materials.new("diffuse_" + key)
            m.use_nodes = True
            nt = m.node_tree
            nt.nodes.clear()
            out = nt.nodes.new("ShaderNodeOutputMaterial")
            bsdf = nt.nodes.new("ShaderNodeBsdfDiffuse")
            bsdf.inputs["Color"].default_value = (*rgb, 1.0)
            bsdf.inputs["Roughness"].default_value = 0.0  # Lambert
            nt.links.new(bsdf.outputs["BSDF"], out.inputs["Surface"])
            mats[key] = m
        return mats[key]

    for o in list(sc.objects):
        if o.type != 'MESH':
            continue
        me = o.data
        assert o.matrix_world == Matrix.Identity(4), (o.name, o.matrix_world)
        me.polygons.foreach_set("use_smooth", [False] * len(me.polygons))  # face normals
        if len(o.material_slots) == 0:
            me.materials.append(diffuse("default", kd_default))
        for slot in o.material_slots:
            mname = slot.material.name.split(".")[0] if slot.material else "default"
            slot.material = diffuse(mname, kd.get(mname, kd_default))

    cam_data = bpy.data.cameras.new("camera")
    cam_data.sensor_fit = 'VERTICAL'
    cam_data.angle_y = math.radians(fov)
    cam_data.clip_start = 1e-3
    cam_data.clip_end = 1e7
    cam = bpy.data.objects.new("camera", cam_data)
    sc.collection.objects.link(cam)
    f = (Vector(vi) - Vector(vp)).normalized()
    r = f.cross(Vector(vu)).normalized()
    u = r.cross(f)
    cam.matrix_world = Matrix.Translation(Vector(vp)) @ Matrix((r, u, -f)).transposed().to_4x4()
    sc.camera = cam

    ld = bpy.data.lights.new("point", 'POINT')     # radiant intensity = power / (4 pi)
    ld.energy = 4.0 * math.pi * intensity
    ld.color = (1.0, 1.0, 1.0)
    ld.shadow_soft_size = 0.0
    ld.use_soft_falloff = False
    lo = bpy.data.objects.new("point", ld)
    lo.location = lpos
    sc.collection.objects.link(lo)

    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    bg.inputs["Strength"].default_value = 0.0
    sc.world = world

    rs = sc.render
    rs.engine = 'CYCLES'
    rs.resolution_x, rs.resolution_y, rs.resolution_percentage = W, H, 100
    rs.threads_mode = 'FIXED'
    rs.threads = threads
    rs.film_transparent = False
    rs.use_motion_blur = False
    rs.use_compositing = False
    rs.use_sequencer = False
    rs.use_persistent_data = False
    c = sc.cycles
    c.device = 'CPU'
    c.samples = spp
    c.use_adaptive_sampling = False
    c.seed = seed
    c.use_animated_seed = False
    c.max_bounces = max_bounces
    c.diffuse_bounces = max_bounces
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    c.pixel_filter_type = 'BOX'
    c.filter_width = 1.0
    c.film_exposure = 1.0
    c.use_guiding = False
    c.use_fast_gi = False
    c.use_denoising = bool(denoise)
    c.denoiser = 'OPENIMAGEDENOISE'
    c.denoising_input_passes = 'RGB_ALBEDO_NORMAL'
    c.denoising_prefilter = 'ACCURATE'
    c.denoising_quality = 'HIGH'
    c.denoising_use_gpu = False
    bpy.context.view_layer.cycles.use_denoising = True   # per view layer; the scene switch decides
    vs = sc.view_settings
    vs.view_transform = 'Standard'
    vs.look = 'None'
    im = rs.image_settings
    im.file_format = 'OPEN_EXR'
    im.color_mode = 'RGB'
    im.color_depth = '32'
    im.exr_codec = 'ZIP'
    return sc


def cycles_child(scene, spp, seed, denoise, out):
    import resource
    t0 = time.perf_counter()
    import bpy
    t_import = time.perf_counter() - t0
    t0 = time.perf_counter()
    sc = build_scene(bpy, scene, spp, THREADS, PATH_LENGTH - 1, seed, denoise)
    t_load = time.perf_counter() - t0
    sys.stdout.flush()
    r0 = resource.getrusage(resource.RUSAGE_SELF)
    t0 = time.perf_counter()
    bpy.ops.render.render(write_still=False)
    t_render = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_SELF)
    sys.stdout.flush()
    if os.path.exists(out):
        os.remove(out)
    bpy.data.images["Render Result"].save_render(filepath=out, scene=sc)
    # bpy.__file__ is the Python package inside the wheel (bpy/4.5/scripts/modules/bpy): the
    # libraries are in bpy/lib, some levels up
    d, oidn = os.path.dirname(bpy.__file__), []
    while not oidn and d != os.path.dirname(d):
        oidn = sorted(glob.glob(os.path.join(d, "lib", "libOpenImageDenoise_core.so.*")))
        d = os.path.dirname(d)
    print("RESULT " + json.dumps({
        "blender": bpy.app.version_string, "oidn_lib": os.path.basename(oidn[-1]) if oidn else None,
        "denoise": bool(sc.cycles.use_denoising), "seed": sc.cycles.seed,
        "import_s": round(t_import, 3), "load_s": round(t_load, 3), "render_s": round(t_render, 3),
        "render_cpu_s": round(r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime, 3)}), flush=True)


# ================================================================= machine state
def cpu_jiffies():
    v = [int(x) for x in open("/proc/stat").readline().split()[1:9]]
    return sum(v), sum(v) - v[3] - v[4]          # total, busy


def cpu_busy_pct(dt=1.0):
    t0, b0 = cpu_jiffies(); time.sleep(dt); t1, b1 = cpu_jiffies()
    return 100.0 * (b1 - b0) / max(1, t1 - t0)


def wait_idle():
    t0 = time.time()
    busy = cpu_busy_pct()
    while busy > 10 and time.time() - t0 < IDLE_MAX_S:
        time.sleep(2)
        busy = cpu_busy_pct()
    return round(time.time() - t0, 1), round(busy, 1)


def psi_some_us():
    try:
        return int(open("/proc/pressure/cpu").readline().split("total=")[1])
    except (OSError, IndexError, ValueError):
        return 0


# ================================================================= running
def img_path(renderer, scene, spp, denoise, seed, keep):
    d = os.path.join(OUT, "img")
    os.makedirs(d, exist_ok=True)
    name = f"{renderer}_{scene}_{spp}spp_{'den' if denoise else 'noisy'}_s{seed}"
    return os.path.join(d, name + (".exr" if keep else ".scratch.exr"))


def command(renderer, scene, spp, denoise, seed, out):
    if renderer == "ember":
        toml = EMBER_CORNELL if scene == "cornell" else EMBER_TEAPOT
        argv = [EMBER, "render", toml, "--width", str(W), "--height", str(H), "--spp", str(spp),
                "--max-depth", str(PATH_LENGTH), "--threads", str(THREADS), "--seed", str(seed), "-o", out]
        return argv + (["--denoise"] if denoise else [])
    return [sys.executable, os.path.abspath(__file__), "--cycles-child", scene, str(spp), str(seed),
            str(int(denoise)), out]


def run(phase, renderer, scene, spp, denoise, seed=SEED, rnd=None, keep=True, timed=True):
    out = img_path(renderer, scene, spp, denoise, seed, keep)
    argv = command(renderer, scene, spp, denoise, seed, out)
    waited, busy = wait_idle() if timed else (0.0, None)
    tfile = os.path.join(OUT, "time.txt")
    p0, j0, t0 = psi_some_us(), cpu_jiffies(), time.time()
    p = subprocess.run(["/usr/bin/time", "-f", "%e %M %U %S", "-o", tfile] + argv, capture_output=True, text=True)
    j1, p1 = cpu_jiffies(), psi_some_us()
    text = p.stdout + p.stderr
    logd = os.path.join(OUT, "logs")
    os.makedirs(logd, exist_ok=True)
    open(os.path.join(logd, f"{phase}_{renderer}_{scene}_{spp}_{int(denoise)}_s{seed}_r{rnd}.log"), "w").write(
        " ".join(argv) + "\n" + text)
    if p.returncode != 0:
        print(text[-3000:], file=sys.stderr)
        raise SystemExit(f"FAILED: {' '.join(argv)}")
    wall, kb, us, ss = open(tfile).read().split()
    cpu = float(us) + float(ss)
    rec = {"phase": phase, "round": rnd, "renderer": renderer, "scene": scene, "spp": spp,
           "denoise": bool(denoise), "seed": seed, "cmd": " ".join(argv), "image": out if keep else None,
           "start": round(t0, 1), "wall_s": float(wall), "cpu_s": round(cpu, 2),
           "peak_rss_mb": round(int(kb) / 1024, 1), "psi_stall_s": round((p1 - p0) / 1e6, 3),
           "other_cpu_s": round((j1[1] - j0[1]) / os.sysconf("SC_CLK_TCK") - cpu, 2),
           "idle_wait_s": waited, "busy_pct_before": busy}
    res = [l for l in p.stdout.splitlines() if l.startswith("RESULT ")]
    if res:
        r = json.loads(res[-1][7:])
        rec.update(render_s=r["render_s"], render_cpu_s=r["render_cpu_s"], child=r)
    m = re.search(r"rendered \d+x\d+ at .*? in ([\d.]+) s", text)
    if m:
        rec["ember_render_s"] = float(m.group(1))
    m = re.search(r"denoised in ([\d.]+) s \(([^;)]*)", text)
    if m:
        rec["ember_denoise_s"], rec["ember_denoiser"] = float(m.group(1)), m.group(2)
    if not keep and os.path.exists(out):
        os.remove(out)
    with open(RUNS, "a") as fh:
        fh.write(json.dumps(rec) + "\n")
    print(f"{phase:6s} r{rnd} {renderer:6s} {scene:7s} {spp:5d} spp {'den  ' if denoise else 'noisy'} "
          f"wall {rec['wall_s']:7.2f} render {rec.get('render_s', '')} cpu {rec['cpu_s']:7.2f} "
          f"psi {rec['psi_stall_s']:.2f} other {rec['other_cpu_s']:.2f} waited {waited} busy {busy}", flush=True)
    return rec


def setup():
    os.makedirs(OUT, exist_ok=True)
    if not os.path.exists(EMBER_SRC):
        raise SystemExit(f"{EMBER_SRC} missing: cargo build --release")
    if not os.path.exists(EMBER):
        shutil.copy2(EMBER_SRC, EMBER)
    open(EMBER_TEAPOT, "w").write(TEAPOT_TOML % TEAPOT_OBJ)


def phase_refs():
    for scene in SCENES:
        for renderer in ("ember", "cycles"):
            run("ref", renderer, scene, REF_SPP, False, seed=REF_SEED, timed=False)


def phase_timing():
    for rnd in range(ROUNDS):
        for scene in SCENES:
            e = [("ember", scene, s, d) for s in EMBER_SPPS for d in (False, True)]
            c = [("cycles", scene, s, d) for s in CYCLES_SPPS for d in (False, True)]
            first, second = (e, c) if rnd % 2 == 0 else (c, e)
            jobs = []
            for i in range(max(len(first), len(second))):
                jobs += first[i:i + 1] + second[i:i + 1]
            for (renderer, sc, spp, d) in jobs:
                run("timing", renderer, sc, spp, d, rnd=rnd, keep=(rnd == 0))


def phase_retime():
    """Runs again, when the machine is idle, every timed configuration with fewer than ROUNDS clean runs
    (see clean()), at most RETIME_MAX more times each."""
    global IDLE_MAX_S
    IDLE_MAX_S = float(os.environ.get("RETIME_IDLE_MAX_S", "120"))
    extra = int(os.environ.get("RETIME_MAX", "3"))
    for k in range(extra):
        runs = [json.loads(l) for l in open(RUNS)]
        todo = []
        for scene in SCENES:
            for renderer, spps in (("ember", EMBER_SPPS), ("cycles", CYCLES_SPPS)):
                for spp in spps:
                    for d in (False, True):
                        rs = [r for r in runs if r["phase"] == "timing" and (r["renderer"], r["scene"], r["spp"],
                                                                              r["denoise"]) == (renderer, scene, spp, d)]
                        if sum(clean(r) for r in rs) < ROUNDS:
                            todo.append((renderer, scene, spp, d))
        print(f"retime pass {k}: {len(todo)} configurations with fewer than {ROUNDS} clean runs", flush=True)
        if not todo:
            return
        for (renderer, scene, spp, d) in todo:
            run("timing", renderer, scene, spp, d, rnd=100 + k, keep=False)


# ================================================================= metrics
def read_exr(path, layer="RGB"):
    import numpy as np
    import OpenEXR
    ch = OpenEXR.File(path).parts[0].channels
    if layer in ch:
        a = ch[layer].pixels
    else:
        pre = "" if layer == "RGB" else layer + "."
        a = np.stack([ch[pre + c].pixels for c in "RGB"], -1)
    return np.asarray(a, dtype=np.float64)[..., :3]


def relmse(x, r):
    import numpy as np
    return float(np.mean((x - r) ** 2 / (r * r + REL_EPS)))


def to_rgb8(a):
    """ember's Film::to_rgb8 with the default look: clamp to [0,1], sRGB encode, *255 + 0.5, truncate."""
    import numpy as np
    c = np.clip(np.nan_to_num(a.astype(np.float32), nan=0.0), 0.0, 1.0)
    s = np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1.0 / 2.4, dtype=np.float32) - 0.055)
    return np.clip(s.astype(np.float32) * 255.0 + 0.5, 0, 255).astype(np.uint8)


def flip(x, r):
    """Mean LDR FLIP at 67 pixels per degree of the 8-bit sRGB images, as `ember converge`."""
    import numpy as np
    import flip_evaluator as fe
    _, mean, _ = fe.evaluate(to_rgb8(r).astype(np.float32) / 255.0, to_rgb8(x).astype(np.float32) / 255.0,
                             "LDR", inputsRGB=True, applyMagma=False, computeMeanError=True,
                             parameters={"ppd": FLIP_PPD})
    return float(mean)


def g(x, spec=".3g"):
    return "n/a" if x is None else format(x, spec)


def clean(r):
    """A timed process during which other work stalled it little: PSI CPU stall <= max(0.5 s, 5% of wall)."""
    return r["psi_stall_s"] <= max(0.5, 0.05 * r["wall_s"])


def med(xs):
    xs = [x for x in xs if x is not None]
    return statistics.median(xs) if xs else None


def interp(points, t):
    """points: [(time, value)], value > 0; value at time t, linear in log-log between the bracketing
    pair (by time). None outside the range."""
    pts = sorted(p for p in points if p[0] and p[1] and p[1] > 0)
    for (t0, v0), (t1, v1) in zip(pts, pts[1:]):
        if t0 <= t <= t1:
            if t1 == t0:
                return v0
            a = (math.log(t) - math.log(t0)) / (math.log(t1) - math.log(t0))
            return math.exp(math.log(v0) + a * (math.log(v1) - math.log(v0)))
    return None


def phase_analyze():
    import numpy as np
    latest = {}
    for r in map(json.loads, open(RUNS)):
        latest[(r["phase"], r["round"], r["renderer"], r["scene"], r["spp"], r["denoise"], r["seed"])] = r
    runs = list(latest.values())
    refs = {(r["renderer"], r["scene"]): r for r in runs if r["phase"] == "ref"}
    timing = [r for r in runs if r["phase"] == "timing"]
    L, rows = [], []
    P = L.append
    P("# ember + OIDN against Cycles + OIDN at equal time (scripts/peers/denoise_vs_cycles.py)\n")
    P(f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; {W}x{H}, path length {PATH_LENGTH}, {THREADS} threads, "
      f"{ROUNDS} rounds, medians; references {REF_SPP} spp, seed {REF_SEED}.\n")
    psis = [r["psi_stall_s"] for r in timing]
    others = [r["other_cpu_s"] for r in timing]
    if timing:
        used = [r for r in timing if clean(r)]
        P(f"Timed processes: {len(timing)}; PSI CPU stall per process: median {med(psis):.2f} s, max {max(psis):.2f} s; "
          f"other processes' CPU during a process: median {med(others):.2f} s, max {max(others):.2f} s. Medians are "
          f"over the {len(used)} clean runs (stall <= max(0.5 s, 5% of the wall time); a configuration with none "
          f"would use all its runs); their stall: median {med([r['psi_stall_s'] for r in used]):.2f} s, max "
          f"{max([r['psi_stall_s'] for r in used] or [0]):.2f} s.\n")
    cy = [r for r in runs if r["renderer"] == "cycles" and "child" in r]
    em = [r for r in runs if r.get("ember_denoiser")]
    if cy:
        P(f"Cycles: Blender {cy[0]['child']['blender']}, {cy[0]['child']['oidn_lib']}. "
          f"ember denoiser: {em[0]['ember_denoiser'] if em else 'n/a'}.\n")
    summary = {}
    for scene in SCENES:
        er, cr = refs.get(("ember", scene)), refs.get(("cycles", scene))
        ref = {k: read_exr(v["image"]) for k, v in (("ember", er), ("cycles", cr)) if v}
        P(f"\n## {scene}\n")
        if len(ref) == 2:
            me, mc = ref["ember"].mean(), ref["cycles"].mean()
            P(f"References: mean linear value ember {me:.5f}, Cycles {mc:.5f} (Cycles / ember {mc / me:.4f}); "
              f"relMSE of Cycles' reference against ember's {relmse(ref['cycles'], ref['ember']):.3g}, "
              f"FLIP {flip(ref['cycles'], ref['ember']):.4f}. Reference renders: ember {er['wall_s']:.1f} s, "
              f"Cycles {cr['render_s']:.1f} s (render call).\n")
        # configurations
        confs = {}
        for r in timing:
            if r["scene"] == scene:
                confs.setdefault((r["renderer"], r["spp"], r["denoise"]), []).append(r)
        stats = {}
        for (renderer, spp, d), rs_all in confs.items():
            rs_all.sort(key=lambda r: r["round"])
            img = next((r["image"] for r in rs_all if r["image"]), None)
            rs = [r for r in rs_all if clean(r)] or rs_all     # medians over the clean runs
            s = dict(renderer=renderer, scene=scene, spp=spp, denoise=d, n=len(rs), n_all=len(rs_all),
                     proc_wall=med([r["wall_s"] for r in rs]), proc_cpu=med([r["cpu_s"] for r in rs]),
                     walls=[r["wall_s"] for r in rs], psi=[r["psi_stall_s"] for r in rs])
            if renderer == "cycles":
                s.update(time=med([r["render_s"] for r in rs]), cpu=med([r["render_cpu_s"] for r in rs]),
                         times=[r["render_s"] for r in rs])
            else:
                s.update(time=s["proc_wall"], cpu=s["proc_cpu"], times=s["walls"],
                         ember_render=med([r.get("ember_render_s") for r in rs]),
                         ember_denoise=med([r.get("ember_denoise_s") for r in rs]))
            if img:
                a = read_exr(img)
                if renderer in ref:
                    s["rel_raw"], s["flip"] = relmse(a, ref[renderer]), flip(a, ref[renderer])
                if "ember" in ref:
                    s["rel_vs_ember"], s["flip_vs_ember"] = relmse(a, ref["ember"]), flip(a, ref["ember"])
                if len(ref) == 2:   # the mean of both references: twice the samples of either
                    both = 0.5 * (ref["ember"] + ref["cycles"])
                    s["rel_vs_both"], s["flip_vs_both"] = relmse(a, both), flip(a, both)
            stats[(renderer, spp, d)] = s
        # the reference's own noise, from the highest-spp noisy render
        for renderer, spps in (("ember", EMBER_SPPS), ("cycles", CYCLES_SPPS)):
            top = stats.get((renderer, max(spps), False))
            ref_rec = refs.get((renderer, scene))
            e_ref = None
            if top and "rel_raw" in top and ref_rec:
                e_ref = top["rel_raw"] / (ref_rec["spp"] / top["spp"] + 1)
            for s in stats.values():
                if s["renderer"] == renderer and "rel_raw" in s:
                    s["e_ref"], s["rel"] = e_ref, (s["rel_raw"] - e_ref if e_ref is not None else None)
            if e_ref is not None:
                P(f"{renderer}'s reference: its own noise adds an estimated {e_ref:.3g} to every relMSE against it "
                  f"(subtracted in 'relMSE'; raw figures in results.csv).\n")
        # table
        P("| renderer | spp | time s (noisy) | relMSE noisy | FLIP noisy | time s (denoised) | of which denoising | relMSE denoised | FLIP denoised |")
        P("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
        for renderer, spps in (("ember", EMBER_SPPS), ("cycles", CYCLES_SPPS)):
            for spp in spps:
                n, d = stats.get((renderer, spp, False)), stats.get((renderer, spp, True))
                if not n or not d:
                    continue
                dn = (d.get("ember_denoise") if renderer == "ember" else
                      (d["time"] - n["time"] if d["time"] and n["time"] else None))
                P(f"| {'ember' if renderer == 'ember' else 'Cycles'} | {spp} | {n['time']:.2f} | {g(n.get('rel'))} | "
                  f"{g(n.get('flip'), '.4f')} | {d['time']:.2f} | {'~' if renderer == 'cycles' else ''}{g(dn, '.2f')} | "
                  f"{g(d.get('rel'))} | {g(d.get('flip'), '.4f')} |")
        P("\nTime: ember = whole process (wall); Cycles = the render call (wall), its denoising = denoised minus noisy "
          "render call. Process times (Cycles: Python start, bpy import, scene build, render, EXR write) and CPU "
          "times are in results.csv.\n")
        # equal time: ember's time is its process; Cycles' the render call, or its whole process
        name = {"ember": "ember + OIDN", "cycles": "Cycles + OIDN"}
        for ck, cl in (("time", "render call"), ("proc_wall", "process")):
            for a_r, b_r in (("ember", "cycles"), ("cycles", "ember")):
                a = stats.get((a_r, 16, True))
                bs = [s for s in stats.values() if s["renderer"] == b_r and s["denoise"]]
                if not a or not bs:
                    continue
                ka, kb = ("time", ck) if a_r == "ember" else (ck, "time")
                t = a[ka]
                vals = {k: interp([(s[kb], s.get(k)) for s in bs], t) for k in ("rel", "flip", "spp")}
                head = (f"- Cycles time = {cl}. At the time {name[a_r]} takes for 16 spp denoised ({t:.2f} s; relMSE "
                        f"{g(a.get('rel'))}, FLIP {g(a.get('flip'), '.4f')}), {name[b_r]}")
                if vals["spp"] is None:
                    P(f"{head} is outside its measured range ({min(s[kb] for s in bs):.2f}-{max(s[kb] for s in bs):.2f} s).")
                else:
                    P(f"{head} reaches ~{vals['spp']:.1f} spp: relMSE {g(vals['rel'])}, FLIP {g(vals['flip'], '.4f')} "
                      f"(log-log interpolation between the two renders whose times bracket it).")
                summary[(scene, a_r, ck)] = dict(t=t, **vals)
        for s in stats.values():
            rows.append(s)
    # csv
    cols = ["scene", "renderer", "spp", "denoise", "n", "n_all", "time", "cpu", "proc_wall", "proc_cpu", "ember_render",
            "ember_denoise", "rel_raw", "e_ref", "rel", "flip", "rel_vs_ember", "flip_vs_ember", "rel_vs_both",
            "flip_vs_both", "times", "psi"]
    with open(os.path.join(OUT, "results.csv"), "w") as fh:
        fh.write(",".join(cols) + "\n")
        for s in sorted(rows, key=lambda s: (s["scene"], s["renderer"], s["spp"], s["denoise"])):
            fh.write(",".join(";".join(map(str, v)) if isinstance(v, list) else
                              ("" if v is None else (f"{v:.6g}" if isinstance(v, float) else str(v)))
                              for v in (s.get(c) for c in cols)) + "\n")
    P("\n## Commands\n")
    seen = set()
    for r in sorted(runs, key=lambda r: r["start"]):
        k = (r["phase"], r["renderer"], r["scene"], r["denoise"])
        if k not in seen:
            seen.add(k)
            P(f"- {r['phase']} {r['renderer']} {r['scene']} {r['spp']} spp{' denoised' if r['denoise'] else ''}: `{r['cmd']}`")
    open(os.path.join(OUT, "results.md"), "w").write("\n".join(L) + "\n")
    print("\n".join(L))


def main(phases):
    setup()
    for p in phases:
        print(f"== {p} ({time.strftime('%H:%M:%S')})", flush=True)
        {"refs": phase_refs, "timing": phase_timing, "retime": phase_retime, "analyze": phase_analyze}[p]()


if __name__ == "__main__":
    a = sys.argv[1:]
    if a and a[0] == "--cycles-child":
        scene, spp, seed, denoise, out = a[1:6]
        cycles_child(scene, int(spp), int(seed), int(denoise), out)
    else:
        main(a or ["refs", "timing", "retime", "analyze"])
