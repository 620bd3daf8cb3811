#!/usr/bin/env python3
"""Where a denoised image departs from the reference: FLIP and relMSE by region, and pixel probes.

Reads a reference (e.g. DIR/reference.exr of `ember converge`) and an EXR written by `ember
render ... --denoise` (main layer = denoised, layer `noisy`), and prints, for the noisy and the
denoised image:
  - relMSE and mean FLIP over the whole image, as `ember converge` computes them (relMSE on linear
    values with eps 0.01; FLIP: LDR, 67 pixels per degree, on 8-bit sRGB made as Film::to_rgb8:
    clamp to [0,1], sRGB encode, *255 + 0.5, truncate);
  - mean FLIP and its share over three regions: edges (pixels within 1 of a jump > 0.08 in the
    reference's 8-bit grey level), noise-free (the noisy pixel equals the reference within 0.1%:
    the background seen directly), and the rest;
  - how much the denoiser changes the noise-free pixels (edges included), and the denoised image's
    relMSE and FLIP with those pixels taken from the noisy image (a diagnostic: the mask comes from
    the reference);
  - with --at X,Y: the mean luminance of the 3x3 pixels around (X, Y) in reference, denoised, noisy;
  - with --row Y,X0,X1,C: channel C (0-2) of row Y, columns X0..X1-1, reference and denoised.

Setup: pip install numpy OpenEXR flip-evaluator (e.g. the venv of scripts/peers/denoise_vs_cycles.py).
Command: python3 scripts/denoise_regions.py REFERENCE.exr DENOISED.exr [--at X,Y]... [--row Y,X0,X1,C]...
"""
import argparse
import os
import sys

import flip_evaluator as fe
import numpy as np

# The EXR reader, relMSE and 8-bit conversion of the Cycles comparison, which are converge's.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "peers"))
from denoise_vs_cycles import FLIP_PPD, read_exr as read, relmse, to_rgb8  # noqa: E402

LUM = np.array([0.2126, 0.7152, 0.0722])


def flip_map(x, r):
    """The FLIP map whose mean is denoise_vs_cycles.flip: per pixel, to split by region."""
    m, _, _ = fe.evaluate(to_rgb8(r).astype(np.float32) / 255.0, to_rgb8(x).astype(np.float32) / 255.0,
                          "LDR", inputsRGB=True, applyMagma=False, parameters={"ppd": FLIP_PPD})
    return np.squeeze(np.asarray(m, dtype=np.float64))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("reference")
    ap.add_argument("image")
    ap.add_argument("--at", action="append", default=[], help="X,Y: 3x3 mean luminance there")
    ap.add_argument("--row", action="append", default=[], help="Y,X0,X1,C: a row of channel C")
    a = ap.parse_args()
    ref, den, noisy = read(a.reference), read(a.image, "RGB"), read(a.image, "noisy")
    grey = to_rgb8(ref).astype(np.float64).mean(2) / 255.0
    gx, gy = np.zeros_like(grey), np.zeros_like(grey)
    gx[:, 1:-1] = grey[:, 2:] - grey[:, :-2]
    gy[1:-1] = grey[2:] - grey[:-2]
    jump = np.hypot(gx, gy) > 0.08
    edge = jump.copy()
    edge[1:] |= jump[:-1]; edge[:-1] |= jump[1:]; edge[:, 1:] |= jump[:, :-1]; edge[:, :-1] |= jump[:, 1:]
    exact = np.abs(noisy - ref).max(2) < 1e-3 * (ref.max(2) + 1e-3)
    free = exact & ~edge
    rest = ~edge & ~free
    fn, fd = flip_map(noisy, ref), flip_map(den, ref)
    print(f"{ref.shape[1]}x{ref.shape[0]}: noisy relMSE {relmse(noisy, ref):.4g} FLIP {fn.mean():.4f}; "
          f"denoised relMSE {relmse(den, ref):.4g} FLIP {fd.mean():.4f}")
    for name, m in (("edges", edge), ("noise-free", free), ("rest", rest)):
        print(f"  {name:10s} {100 * m.mean():5.1f}% of the pixels: FLIP noisy {fn[m].mean():.4f} denoised "
              f"{fd[m].mean():.4f}; share of the image's FLIP noisy {100 * fn[m].sum() / fn.sum():.0f}% "
              f"denoised {100 * fd[m].sum() / fd.sum():.0f}%")
    rel = (np.abs(den - ref) / (ref + 1e-3)).max(2)[exact]
    changed = (to_rgb8(den) != to_rgb8(ref)).any(-1)[exact]
    kept = np.where(exact[..., None], noisy, den)
    print(f"  noise-free pixels, edges included ({100 * exact.mean():.1f}%): denoised differs by {100 * rel.mean():.2f}% on average, {100 * rel.max():.1f}% at most; "
          f"8-bit value changed in {100 * changed.mean():.0f}% of them")
    print(f"  denoised with the noise-free pixels taken from the noisy image: relMSE {relmse(kept, ref):.4g}, "
          f"FLIP {flip_map(kept, ref).mean():.4f}")
    for s in a.at:
        x, y = (int(v) for v in s.split(","))
        sl = (slice(y - 1, y + 2), slice(x - 1, x + 2))
        print(f"  3x3 mean luminance at ({x},{y}): reference {(ref[sl] @ LUM).mean():.3f}, denoised "
              f"{(den[sl] @ LUM).mean():.3f}, noisy {(noisy[sl] @ LUM).mean():.3f}")
    for s in a.row:
        y, x0, x1, c = (int(v) for v in s.split(","))
        print(f"  row {y}, x {x0}..{x1 - 1}, channel {c}: reference " + " ".join(f"{v:.2f}" for v in ref[y, x0:x1, c]))
        print(f"  {' ' * (len(str(y)) + len(str(x0)) + len(str(x1 - 1)) + 23)}denoised  "
              + " ".join(f"{v:.2f}" for v in den[y, x0:x1, c]))


if __name__ == "__main__":
    main()
