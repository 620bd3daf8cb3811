#!/usr/bin/env python3
"""The peers comparison (shared/peers/compare_all.py) with ember configurations of our own.

compare_all.py times ember, Intel's Embree tutorial, Mitsuba 3 and Blender Cycles on two matched
scenes (Embree's Cornell box and the Utah teapot, 512x512, 64 spp, path length 8, 2 threads) and
measures each image's relMSE against the renderer's own 1,024-spp reference. Its ember
configurations are the defaults (adaptive sampling) and --no-robust. This driver loads it
from PEERS_DIR (../shared/peers by default; it is not part of this repository) and adds:
  ember_uniform       ember --uniform (every pixel takes 64 samples)
  ember_old           another build of ember (the binary EMBER_OLD), defaults
Its warm-up and reference phases keep to CONFIGS (compare_all.py's own also run Cycles and the
tutorial), and `rounds` prints the efficiency of every ember configuration against Mitsuba
(llvm_ad_rgb, Russian roulette off) round by round: 1 / (relMSE x time), each round's times,
relMSE from the `analyze` summary (the images are the same in every round).

Setup: that of shared/peers/README.md (Debian's embree-tools, libllvm19 and time; a venv with
mitsuba==3.9.1 drjit pillow numpy OpenEXR), and a release build of ember.
Command, from the repository root (~25 min with the references, ~10 min without):
    SCRATCH=/tmp/peers/run CONFIGS="ember ember_uniform mitsuba_rroff" ROUNDS=5 \\
        VENV/bin/python scripts/peers/compare_configs.py warmup refs timing analyze rounds
Phases and the other environment variables (SCRATCH, EMBER, ROUNDS, REF_SPP, IDLE_MAX_S,
LOAD_MAX, MITSUBA_PYTHON: this python by default) are compare_all.py's; results go to
RESULTS_DIR (default $SCRATCH/results).
"""
import csv
import importlib.util
import json
import os
import statistics
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
PEERS_DIR = os.environ.get("PEERS_DIR") or os.path.normpath(os.path.join(HERE, "..", "..", "..", "shared", "peers"))
# Results beside the run's records, not in PEERS_DIR (compare_all.py's default).
os.environ.setdefault("RESULTS_DIR", os.path.join(
    os.environ.get("SCRATCH") or os.path.join(os.environ.get("TMPDIR") or "/tmp", "peers", "compare"), "results"))
# Mitsuba's child processes run under this python (the venv's), as broad_suite.py's do;
# compare_all.py's own default is $TMPDIR/peers/venv.
os.environ.setdefault("MITSUBA_PYTHON", sys.executable)
sys.path.insert(0, PEERS_DIR)  # compare_all.py imports run_mitsuba / run_cycles from beside itself
spec = importlib.util.spec_from_file_location("compare_all", os.path.join(PEERS_DIR, "compare_all.py"))
ca = importlib.util.module_from_spec(spec)
spec.loader.exec_module(ca)

# name: (ember flags, the variable naming its binary or None for EMBER, label)
EXTRA = {
    "ember_uniform": (["--uniform"], None, "ember --uniform"),
    "ember_old": ([], "EMBER_OLD", "ember (EMBER_OLD), defaults"),
}
ca.LABEL.update({cfg: label for cfg, (_, _, label) in EXTRA.items()})
ca.SELF_REF.update({cfg: "ember" for cfg in EXTRA})
_command = ca.command


def command(cfg, scene, spp, seed, threads, out, extra=()):
    if cfg not in EXTRA:
        return _command(cfg, scene, spp, seed, threads, out, extra)
    flags, binary, _ = EXTRA[cfg]
    argv, env = _command("ember", scene, spp, seed, threads, out, tuple(extra) + tuple(flags))
    if binary:
        if not os.environ.get(binary):
            raise SystemExit(f"{cfg} needs {binary}=path/to/ember")
        argv[0] = os.environ[binary]
    return argv, env


def phase_warmup():
    # Untimed: the page cache, and Dr.Jit's on-disk kernel cache for the Mitsuba configurations.
    for scene in ca.SCENES:
        for cfg in ca.CONFIGS:
            spp = ca.SPP if cfg.startswith("mitsuba") else 4
            ca.run("warmup", cfg, scene, spp, tag="warm", timed=False)


def phase_refs():
    for scene in ca.SCENES:
        for cfg in [c for c in ("ember", "tutorial", "mitsuba_rroff", "cycles") if c in ca.CONFIGS]:
            seed = ca.MI_REF_SEED if cfg.startswith("mitsuba") else ca.REF_SEED
            ca.run("ref", cfg, scene, ca.REF_SPP, seed=seed, tag="ref")


def phase_rounds():
    """Efficiency against Mitsuba (rr off) round by round, from the timing records and the
    relMSE (float, corrected for the reference's noise) of the last `analyze`."""
    summary = os.path.join(ca.RESULTS, "compare_all.tsv")
    rel = {(r["scene"], r["cfg"]): float(r["relmse_own_float"])
           for r in csv.DictReader(open(summary), delimiter="\t") if r["relmse_own_float"] not in ("", "None")}
    times = {}
    for r in map(json.loads, open(ca.RUNS)):
        if r["phase"] == "timing" and r["cfg"] in ca.CONFIGS:
            times[(r["scene"], r["cfg"], r["round"])] = r.get("render_s", r["wall_s"])
    print("efficiency / Mitsuba llvm_ad_rgb rr off, round by round (relMSE x time of Mitsuba / of ember)")
    for scene in ca.SCENES:
        m = "mitsuba_rroff"
        for cfg in [c for c in ca.CONFIGS if c.startswith("ember")]:
            if (scene, cfg) not in rel or (scene, m) not in rel:
                continue
            rounds = sorted({k[2] for k in times if k[:2] == (scene, cfg) and (scene, m, k[2]) in times})
            ratios = [rel[(scene, m)] * times[(scene, m, r)] / (rel[(scene, cfg)] * times[(scene, cfg, r)])
                      for r in rounds]
            if ratios:
                print(f"  {scene:8s} {cfg:20s} median {statistics.median(ratios):.2f}x  rounds "
                      + " ".join(f"{x:.2f}" for x in ratios))


ca.command = command
ca.phase_warmup = phase_warmup
ca.phase_refs = phase_refs

if __name__ == "__main__":
    phases = sys.argv[1:] or ["warmup", "refs", "timing", "analyze", "rounds"]
    known = {"warmup", "timing", "scaling", "refs", "checks", "analyze", "rounds"}
    if set(phases) - known:
        raise SystemExit(f"unknown phase(s) {sorted(set(phases) - known)}; phases: {sorted(known)}")
    if "analyze" in phases and "ember" not in ca.CONFIGS:
        raise SystemExit('analyze compares every configuration with ember\'s defaults: CONFIGS must include "ember"')
    rest = [p for p in phases if p != "rounds"]
    if rest:
        ca.main(rest)
    if "rounds" in phases:
        phase_rounds()
