#!/usr/bin/env python3
"""Where Russian roulette should start: efficiency of `ember render --rr-depth K` for several K
on several scenes, measured against each scene's reference.

For each scene file: a reference (REF_SPP samples in every pixel, seed 1, roulette off), then
`ember render SCENE --rr-depth K` for each K in DEPTHS (and `auto`) with SEEDS seeds at the
scene's own settings (adaptive sampling, its spp), one after another. Per setting it prints the
mean relMSE against the reference (mean of (x - ref)^2 / (ref^2 + 0.01) over pixels and
channels: `relmse` of scripts/peers/denoise_vs_cycles.py, whose EXR reader it also uses), the CPU seconds of the render process, and the efficiency
1 / (relMSE x CPU) relative to `auto`. The reference's own noise is in every relMSE alike.

The scene `dark-box` is written by this script: scenes/cornell.toml with every colour of
cornell_box.mtl times 0.7 (walls 0.7, so a = 0.7) and max_depth 32, the case of long paths
that roulette is for.

Usage (numpy and OpenEXR needed, e.g. the peers' Mitsuba venv):
    python3 scripts/rr_start.py [--depths 2,4,7,off] [--seeds 3] [--ref-spp 1024] SCENE.toml|dark-box ...
Environment: EMBER (default target/release/ember), THREADS (2), OUT (a temporary folder).
"""
import argparse
import importlib.util
import os
import resource
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
EMBER = os.environ.get("EMBER") or os.path.join(ROOT, "target", "release", "ember")
THREADS = os.environ.get("THREADS", "2")
# The EXR reader and relMSE of the denoiser comparison (its import runs nothing).
_spec = importlib.util.spec_from_file_location("metrics", os.path.join(ROOT, "scripts", "peers", "denoise_vs_cycles.py"))
metrics = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(metrics)


def render(scene, out, args):
    """Renders; returns the CPU seconds (user + system) of the ember process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    r = subprocess.run([EMBER, "render", scene, "-o", out, "--threads", THREADS, *args], capture_output=True, text=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if r.returncode != 0:
        sys.exit(f"ember render {scene} failed:\n{r.stderr}")
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def dark_box(out_dir):
    """Writes the dark box (see the module text) into out_dir; returns its scene file."""
    scenes = os.path.join(ROOT, "scenes")
    with open(os.path.join(scenes, "cornell_box.mtl")) as f:
        mtl = "".join(
            "Kd " + " ".join(f"{0.7 * float(v):g}" for v in line.split()[1:]) + "\n" if line.startswith("Kd ") else line
            for line in f
        )
    with open(os.path.join(out_dir, "cornell_box.mtl"), "w") as f:
        f.write(mtl)
    with open(os.path.join(scenes, "cornell_box.obj")) as f, open(os.path.join(out_dir, "cornell_box.obj"), "w") as g:
        g.write(f.read())
    with open(os.path.join(scenes, "cornell.toml")) as f:
        toml = f.read().replace("max_depth = 8", "max_depth = 32")
    path = os.path.join(out_dir, "dark-box.toml")
    with open(path, "w") as f:
        f.write(toml)
    return path


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--depths", default="2,3,4,5,7,off")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--ref-spp", type=int, default=1024)
    a = ap.parse_args()
    out_dir = os.environ.get("OUT") or tempfile.mkdtemp(prefix="rr_start.")
    os.makedirs(out_dir, exist_ok=True)
    settings = ["auto"] + [d for d in a.depths.split(",") if d != "auto"]
    for scene in a.scenes:
        if scene == "dark-box":
            scene = dark_box(out_dir)
        name = os.path.splitext(os.path.basename(scene))[0]
        ref_path = os.path.join(out_dir, f"{name}_ref.exr")
        if not os.path.exists(ref_path):
            render(scene, ref_path, ["--spp", str(a.ref_spp), "--uniform", "--seed", "1", "--rr-depth", "off"])
        ref = metrics.read_exr(ref_path)
        rows = []
        for rr in settings:
            errs, cpus = [], []
            for s in range(a.seeds):
                img = os.path.join(out_dir, f"{name}_{rr}_{s}.exr")
                cpus.append(render(scene, img, ["--seed", str(10 + s), "--rr-depth", rr]))
                errs.append(metrics.relmse(metrics.read_exr(img), ref))
            rows.append((rr, float(np.mean(errs)), float(np.mean(cpus))))
        e0, t0 = rows[0][1], rows[0][2]
        print(f"\n{scene} ({a.seeds} seeds, reference {a.ref_spp} spp)")
        print("| --rr-depth | relMSE | CPU s | efficiency vs auto |")
        print("|---|--:|--:|--:|")
        for rr, e, t in rows:
            print(f"| {rr} | {e:.6f} | {t:.2f} | {e0 * t0 / (e * t):.2f} |")


if __name__ == "__main__":
    main()
