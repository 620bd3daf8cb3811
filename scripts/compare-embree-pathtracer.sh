#!/usr/bin/env bash
# Renders Embree's Cornell box with Intel's Embree `pathtracer` tutorial (Debian package
# embree-tools) and with ember (scenes/cornell.toml, the same scene) on this machine, in
# rounds, and prints both wall times and their ratio.
#
# Equal path semantics: 512x512, 64 spp, path length 8 (the tutorial's --max-path-length counts
# bounces, each with one shadow ray per light; ember's --max-depth 8 is the same), 2 threads,
# and no Russian roulette, light vertices or adaptive sampling in ember (the tutorial, a
# unidirectional path tracer taking the same samples in every pixel, has none of them): the
# same rays' work, timed.
#
# Usage: scripts/compare-embree-pathtracer.sh [OUT_DIR]   (default: target/compare-embree)
# Environment: SIZE (512), SPP (64), DEPTH (8), THREADS (2), ROUNDS (3: each round times the
# tutorial and ember's three runs; medians and ranges of the ratios are printed at the end),
# PATH_LOOP (auto, ember's default: ember's --path-loop, auto, scalar or wavefront; all render the same image).
#
# ember runs three times: with its defaults (robust; the low-quality BVH it builds for a scene
# this small), with the tutorial's Embree settings (--no-robust --bvh-quality medium), and
# without the robust flag on its own low-quality BVH (--no-robust).
#
# Images: OUT_DIR/pathtracer.ppm (the tutorial writes linear values, clamped, without the sRGB
# curve) and OUT_DIR/ember.png (sRGB, default settings). When python3 with Pillow is available, the mean linear
# RGB of both is printed, which should agree within noise and 8-bit rounding.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
out=${1:-$root/target/compare-embree}
size=${SIZE:-512}
spp=${SPP:-64}
depth=${DEPTH:-8}
threads=${THREADS:-2}
rounds=${ROUNDS:-3}
path_loop=${PATH_LOOP:-auto}

if ! command -v pathtracer >/dev/null; then
    echo "error: pathtracer not found (apt-get install embree-tools)" >&2
    exit 2
fi
ecs=$(dpkg -L embree-tools 2>/dev/null | grep '/cornell_box\.ecs$' | head -n 1 || true)
ecs=${ecs:-/usr/share/doc/embree3/models/cornell_box.ecs}
if [ ! -f "$ecs" ]; then
    echo "error: $ecs: no such file (the scene ships with embree-tools)" >&2
    exit 2
fi
mkdir -p "$out"

(cd "$root" && cargo build --release --quiet)
ember=$root/target/release/ember

# Prints "wall user system" seconds of a command; its own output goes to the log file.
TIMEFORMAT='%R %U %S'
timed() {
    local log=$1 times
    shift
    if ! times=$( { time "$@" >"$log" 2>&1; } 2>&1 ); then
        echo "error: $1 failed, see $log" >&2
        exit 2
    fi
    echo "$times"
}

echo "scene: $ecs = $root/scenes/cornell.toml; ${size}x${size}, $spp spp, path length $depth, $threads threads;" \
    "ember's $path_loop path loop"
echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg)"

# ember three ways: its defaults (robust BVH, low quality: what `ember render` builds for at
# most 1,000 triangles), the tutorial's Embree settings (no robust flag, medium quality), and
# no robust flag with the low-quality build, the fastest on this 34-triangle box (ember bench
# --scene scenes/cornell_box.obj).
variants=("default (robust, low)|" "--no-robust --bvh-quality medium (as the tutorial)|--no-robust --bvh-quality medium" "--no-robust (low)|--no-robust")
# Each round runs the tutorial and then the three ember variants, so a change in the
# machine's load between rounds affects both sides of a round's ratios alike; the medians over
# the rounds are printed at the end.
ratios=$(mktemp)
trap 'rm -f "$ratios"' EXIT
for round in $(seq "$rounds"); do
    echo "round $round of $rounds"
    pt_times=$(timed "$out/pathtracer.log" \
        pathtracer -c "$ecs" --size "$size" "$size" --spp "$spp" --max-path-length "$depth" \
        --threads "$threads" -o "$out/pathtracer.ppm")
    read -r pt_wall pt_user pt_sys <<<"$pt_times"
    pt_cpu=$(echo "$pt_user $pt_sys" | awk '{print $1 + $2}')
    printf '  %-52s %7.2f s wall, %7.2f s CPU\n' "pathtracer (Embree tutorial: scene flags 0, medium)" "$pt_wall" "$pt_cpu"
    for i in "${!variants[@]}"; do
        v=${variants[$i]}
        label=${v%%|*}
        flags=${v#*|}
        tag=$(echo "$flags" | tr -d ' -')
        # shellcheck disable=SC2086
        em_times=$(timed "$out/ember$tag.log" \
            "$ember" render "$root/scenes/cornell.toml" -o "$out/ember$tag.png" --width "$size" --height "$size" \
            --spp "$spp" --max-depth "$depth" --rr-depth off --light-vertices off --uniform --threads "$threads" --path-loop "$path_loop" $flags)
        read -r em_wall em_user em_sys <<<"$em_times"
        em_cpu=$(echo "$em_user $em_sys" | awk '{print $1 + $2}')
        wall_ratio=$(echo "$pt_wall $em_wall" | awk '{print $1 / $2}')
        cpu_ratio=$(echo "$pt_cpu $em_cpu" | awk '{print $1 / $2}')
        printf '  %-52s %7.2f s wall, %7.2f s CPU; pathtracer/ember %.2f (wall), %.2f (CPU)\n' "ember $label" \
            "$em_wall" "$em_cpu" "$wall_ratio" "$cpu_ratio"
        echo "$i $wall_ratio $cpu_ratio" >>"$ratios"
    done
done
# "median (min-max)" of the numbers on standard input.
summary() { sort -n | awk '{v[NR] = $1} END {printf "%.2f (%.2f-%.2f)", (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2, v[1], v[NR]}'; }
echo "pathtracer/ember, median of $rounds rounds (range):"
for i in "${!variants[@]}"; do
    label=${variants[$i]%%|*}
    printf '  %-52s %s wall, %s CPU\n' "ember $label" \
        "$(awk -v i="$i" '$1 == i {print $2}' "$ratios" | summary)" "$(awk -v i="$i" '$1 == i {print $3}' "$ratios" | summary)"
done
echo "load average after:  $(cut -d' ' -f1-3 /proc/loadavg)"
echo "(a ratio above 1 means ember is faster)"
sed -n 's/^rendered/ember (default): rendered/p' "$out/ember.log"

if python3 -c 'import PIL' 2>/dev/null; then
    python3 - "$out/pathtracer.ppm" "$out/ember.png" <<'EOF'
import sys
from PIL import Image

def srgb_to_linear(c):
    c /= 255.0
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4

def mean_linear(path, decode):
    im = Image.open(path).convert("RGB")
    h = im.histogram()  # 256 counts per channel
    n = im.width * im.height
    return [sum(h[256 * k + v] * decode(v) for v in range(256)) / n for k in range(3)]

pt = mean_linear(sys.argv[1], lambda v: v / 255.0)  # the tutorial writes linear values
em = mean_linear(sys.argv[2], srgb_to_linear)
print("mean linear RGB: pathtracer (%.4f, %.4f, %.4f), ember (%.4f, %.4f, %.4f)" % (*pt, *em))
EOF
fi
echo "images: $out/pathtracer.ppm (linear), $out/ember.png (sRGB)"
